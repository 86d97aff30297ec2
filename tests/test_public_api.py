"""The public face of the package: ``score4.__all__``, imported lazily, never Geant4."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

import score4

# the entry points the package promises (score4/__init__.py); a removal must be deliberate
PROMISED = {
    "load_config",
    "RunConfig",
    "plan_run",
    "RunPlan",
    "run",
    "read_results",
    "Results",
    "build_surface",
    "Surface",
    "load_surface",
    "save_surface",
    "api",
    "Score4Error",
    "ConfigError",
}


def _fresh(code: str) -> dict:
    """Run ``code`` in a fresh interpreter; it prints one JSON value as its last line."""
    done = subprocess.run(
        [sys.executable, "-c", code], check=False, capture_output=True, text=True, timeout=120
    )
    assert done.returncode == 0, done.stderr[-2000:]
    return json.loads(done.stdout.strip().splitlines()[-1])


def test_import_is_cheap_and_never_loads_geant4() -> None:
    code = (
        "import sys, json, score4; "
        "print(json.dumps({'all': score4.__all__, "
        "'loaded': sorted(m for m in sys.modules if m.startswith(('score4.', 'geant4_pybind', "
        "'h5py', 'pydantic', 'dask')))}))"
    )
    seen = _fresh(code)
    assert set(seen["all"]) == PROMISED | {"__version__"}
    # importing the package imports none of its modules nor a heavy dependency
    assert seen["loaded"] == []


def test_every_public_name_resolves_without_geant4() -> None:
    code = (
        "import sys, json, score4; "
        "names = {n: type(getattr(score4, n)).__name__ for n in score4.__all__}; "
        "print(json.dumps({'names': names, 'g4': 'geant4_pybind' in sys.modules}))"
    )
    seen = _fresh(code)
    assert seen["g4"] is False, "resolving score4.__all__ imported geant4_pybind"
    assert set(seen["names"]) == set(score4.__all__)
    assert seen["names"]["api"] == "module"
    assert seen["names"]["run"] == "function"


def test_public_names_are_the_implementations() -> None:
    from score4.inputs.config import load_config
    from score4.runner.engine import run
    from score4.runner.output import read_results
    from score4.runner.run_plan import plan_run

    assert score4.load_config is load_config
    assert score4.plan_run is plan_run
    assert score4.run is run
    assert score4.read_results is read_results
    assert score4.api.plan_run is plan_run
    from importlib.metadata import version

    assert score4.__version__ == version("score4")


def test_dir_shows_the_public_face_and_unknown_names_fail() -> None:
    assert set(score4.__all__) == set(score4._PUBLIC) | {"__version__"}
    assert set(score4.__all__) <= set(dir(score4))
    with pytest.raises(AttributeError, match="no attribute 'simulate'"):
        score4.simulate  # noqa: B018


def test_api_uses_only_public_names_of_score4() -> None:
    """score4.api imports no underscored name from another score4 module."""
    import ast
    from pathlib import Path

    tree = ast.parse(Path(score4.api.__file__).read_text())
    private = [
        f"{node.module}.{alias.name}"
        for node in ast.walk(tree)
        if isinstance(node, ast.ImportFrom) and node.level > 0
        for alias in node.names
        if alias.name.startswith("_")
    ]
    assert private == []


def test_a_run_through_the_public_face_leaves_geant4_to_the_worker(tmp_path) -> None:
    """load_config -> plan_run -> run -> read_results, in a fresh parent process that never
    imports geant4_pybind (the chunk runs in a spawned worker)."""
    import yaml

    from conftest import BASE_CONFIG

    config = tmp_path / "run.yaml"
    config.write_text(yaml.safe_dump(BASE_CONFIG))
    out = tmp_path / "run.h5"
    code = (
        "import sys, json, score4; "
        f"plan = score4.plan_run(score4.load_config({str(config)!r})); "
        f"score4.run(plan, {str(out)!r}, jobs=1, progress=False, echo=lambda m: None); "
        f"r = score4.read_results({str(out)!r}); "
        "print(json.dumps({'n': r.n_events, 'seed': r.run['seed'], "
        "'physics': r.run['physics_mode'], "
        "'deposited': bool((r.edep['crystal'] > 0).any()), "
        "'g4': 'geant4_pybind' in sys.modules}))"
    )
    seen = _fresh(code)
    assert seen == {"n": 100, "seed": 7, "physics": "lite", "deposited": True, "g4": False}
