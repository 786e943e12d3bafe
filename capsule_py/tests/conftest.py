"""Shared fixtures: the repository, the `capsule` command the bindings are checked against."""

import json
import os
import pathlib
import subprocess

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]


def cli_path() -> pathlib.Path:
    """The `capsule` binary in $CAPSULE_BIN (a directory, as for the Rust tests), else the
    workspace's debug build (`cargo build`)."""
    env = os.environ.get("CAPSULE_BIN")
    p = (pathlib.Path(env) if env else ROOT / "target" / "debug") / "capsule"
    if not p.exists():
        pytest.fail(f"{p} not found: run `cargo build -p capsule_cli` (or set CAPSULE_BIN)")
    return p


@pytest.fixture(scope="session")
def root() -> pathlib.Path:
    return ROOT


@pytest.fixture(scope="session")
def cli():
    """Run `capsule ARGS...`; returns the CompletedProcess (text), within 120 s."""
    exe = cli_path()

    def run(*args, check=True):
        p = subprocess.run([str(exe), *map(str, args)], capture_output=True, text=True,
                           timeout=120, cwd=ROOT)
        if check and p.returncode != 0:
            pytest.fail(f"capsule {' '.join(map(str, args))}: exit {p.returncode}\n{p.stderr}")
        return p

    return run


@pytest.fixture(scope="session")
def cli_json(cli):
    return lambda *args: json.loads(cli(*args).stdout)


@pytest.fixture(autouse=True)
def at_root(monkeypatch):
    """Every test runs in the repository (scene paths as the README writes them)."""
    monkeypatch.chdir(ROOT)


def _newest(paths):
    return max((f.stat().st_mtime for p in paths for f in p.rglob("*") if f.is_file()), default=0)


@pytest.fixture(scope="session", autouse=True)
def installed_is_current():
    """The installed `capsule` must be built from the sources in this tree (a stale install
    would test old code): its extension is newer than every Rust and Python source it holds."""
    import capsule
    ext = pathlib.Path(capsule._capsule.__file__)
    sources = [ROOT / "capsule_py" / "src", ROOT / "capsule_py" / "python",
               ROOT / "capsule_analysis" / "src", ROOT / "capsule_plant" / "src",
               ROOT / "capsule_controller" / "src"]
    if ext.stat().st_mtime < _newest(sources):
        pytest.fail(f"{ext} is older than the sources: reinstall with "
                    "`pip install ./capsule_py` (or bash .ci/python-setup.sh)")
