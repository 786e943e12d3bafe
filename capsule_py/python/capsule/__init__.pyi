"""Type stubs of the `capsule` package (editors complete from these)."""

import os
from typing import Any, Callable, Dict, Optional, Sequence, Tuple, Union

import numpy as np

from ._capsule import Interrupted as Interrupted
from ._capsule import SceneError as SceneError
from ._capsule import SimulationError as SimulationError

__version__: str
PARAMS: Tuple[str, ...]
SCENE_KEYWORDS: Dict[str, str]
HISTORY_COLUMNS: Tuple[str, ...]

Number = Union[int, float]
SceneLike = Union["Scene", str, os.PathLike, None]

class Scene:
    def __init__(self, path: Union[str, os.PathLike, None] = None, *, text: Optional[str] = None,
                 name: str = ..., friction: str = ..., alpha: Number = ..., omega: Number = ...,
                 gamma: Number = ..., beta: Number = ..., delta: Number = ..., xi: Number = ...,
                 kp: Number = ..., x0: Sequence[Number] = ..., periods: int = ...,
                 transient: int = ..., method: str = ..., tol: Number = ..., step: Number = ...,
                 mu_v: Number = ..., v_s: Number = ..., tau_d: Number = ...,
                 k_s: Number = ...) -> None: ...
    def replace(self, **overrides: Any) -> "Scene": ...
    def to_toml(self) -> str: ...
    def to_dict(self) -> Dict[str, Any]: ...
    def __getitem__(self, keyword: str) -> Any: ...

def simulate(scene: SceneLike = None, *, samples_per_period: int = 0,
             pulse_kp: Optional[float] = None, pulse_at: Optional[int] = None,
             pulse_periods: int = 1, kp_after: Optional[float] = None, stability: bool = False,
             **overrides: Any) -> Dict[str, Any]: ...
def sweep(param: str, values: Sequence[float], scene: SceneLike = None, *, follow: bool = False,
          lyapunov: bool = False, **overrides: Any) -> Dict[str, Any]: ...
def basins(scene: SceneLike = None, *, grid: Tuple[int, int] = (100, 100),
           x_range: Tuple[float, float] = (-2.0, 2.0), y_range: Tuple[float, float] = (-2.0, 2.0),
           plane: str = "x1-x2,y1-y2", known_tol: float = 1e-4,
           basin_method: str = "known-cells",
           cell: Optional[float] = None, cell_hits: int = 2, cell_check: int = 200,
           **overrides: Any) -> Dict[str, Any]: ...
def continue_branch(param: str, to: float, scene: SceneLike = None, *, arc_step: float = 0.01,
                    max_arc_step: float = 0.02, max_points: int = 5000,
                    **overrides: Any) -> Dict[str, Any]: ...
def floquet(scene: SceneLike = None, *, x: Optional[Sequence[float]] = None,
            period: Optional[int] = None, **overrides: Any) -> Dict[str, Any]: ...
def lyapunov(scene: SceneLike = None, **overrides: Any) -> Dict[str, Any]: ...
def identify(recording: Union[str, "os.PathLike[str]"], free: Sequence[str],
             scene: SceneLike = None, *, segment: Optional[Tuple[float, float]] = None,
             validate: Optional[Union[str, "os.PathLike[str]"]] = None,
             patience: Optional[int] = None, **overrides: Any) -> Dict[str, Any]: ...
def study(store: Union[str, os.PathLike], *, kind: str = "simulate",
          grid: Optional[Dict[str, Sequence[float]]] = None,
          points: Optional[Sequence[Dict[str, float]]] = None, scene: SceneLike = None,
          options: Optional[Dict[str, Any]] = None, scheduler: Optional[str] = None,
          workers: int = 2, threads_per_worker: int = 1, batch: Optional[int] = None,
          max_points: int = 100000, progress: Optional[Callable[[int, int], None]] = None,
          **overrides: Any) -> Any:
    """A parameter study on Dask (capsule.parameter_study.run); returns a pandas DataFrame."""
