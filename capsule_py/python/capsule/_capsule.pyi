"""The extension module (Rust, PyO3): the thin layer the `capsule` package wraps. Scenes cross as
complete scene files (TOML text), results as the `capsule` command's JSON text, arrays as bytes."""

from typing import Any, Dict, List, Optional, Sequence, Tuple

__version__: str

class SceneError(ValueError):
    """A scene refused: the source, the key and the reason."""

class SimulationError(RuntimeError):
    """A run that failed while working."""

class Interrupted(KeyboardInterrupt):
    """Ctrl-C stopped the work; ``partial`` holds what finished."""
    partial: Any

def resolve_scene(path: Optional[str] = None, text: Optional[str] = None,
                  overrides: Optional[Dict[str, Any]] = None,
                  source: Optional[str] = None) -> str: ...
def scene_json(toml_text: str) -> str: ...
def scene_keywords() -> List[Tuple[str, str]]: ...
def params() -> List[str]: ...
def simulate(scene: str, samples_per_period: int = 0,
             pulse: Optional[Tuple[float, int, int]] = None, kp_after: Optional[float] = None,
             stability: bool = False) -> Tuple[str, Optional[bytes]]: ...
def sweep(scene: str, param_name: str, values: Sequence[float], follow: bool = False,
          lyapunov: bool = False) -> str: ...
def basins(scene: str, nx: int, ny: int, x_range: Tuple[float, float],
           y_range: Tuple[float, float], plane: str, known_tol: float, basin_method: str,
           cell: Optional[float], cell_hits: int, cell_check: int) -> Tuple[str, bytes]: ...
def continue_branch(scene: str, param_name: str, to: float, arc_step: float = 0.01,
                    max_arc_step: float = 0.02, max_points: int = 5000) -> str: ...
def floquet(scene: str, x: Optional[Sequence[float]] = None,
            period: Optional[int] = None) -> str: ...
def lyapunov(scene: str) -> str: ...
def identify(recording: str, scene: str, free: List[str],
             segment: Optional[Tuple[float, float]] = None, validate: Optional[str] = None,
             patience: Optional[int] = None) -> str: ...
