"""score4: radioactive contamination on and below rough surfaces, simulated with Geant4.

The public face is the names of ``__all__``; everything else under ``score4.`` is internal (its
modules may move between releases). Each name is imported on first use, so ``import score4``
stays cheap and never imports Geant4::

    import score4

    config = score4.load_config("run.yaml")          # validated RunConfig
    plan = score4.plan_run(config)                   # the resolved run, made once
    path = score4.run(plan, "out.h5", jobs=2)        # workers import Geant4, this process never
    results = score4.read_results(path)              # events, primaries, the run record
    surface = score4.build_surface(score4.load_surface_spec("surface.yaml"))

``score4.api`` is the library for your own geant4_pybind application (it imports Geant4).
"""

from importlib import import_module
from importlib.metadata import PackageNotFoundError, version
from typing import Any

try:
    __version__ = version("score4")
except PackageNotFoundError:  # running from a source tree without installation
    __version__ = "0.0.0+unknown"

# public name -> the module that defines it
_PUBLIC = {
    "load_config": "score4.inputs.config",
    "RunConfig": "score4.inputs.config",
    "plan_run": "score4.runner.run_plan",
    "RunPlan": "score4.runner.run_plan",
    "run": "score4.runner.engine",
    "read_results": "score4.runner.output",
    "Results": "score4.runner.output",
    "load_surface_spec": "score4.surface.spec",
    "build_surface": "score4.surface.spec",
    "Surface": "score4.surface.spec",
    "load_surface": "score4.surface.store",
    "save_surface": "score4.surface.store",
    "Score4Error": "score4.errors",
    "ConfigError": "score4.errors",
}

__all__ = ["__version__", "api", *sorted(_PUBLIC)]


def __getattr__(name: str) -> Any:
    if name == "api":
        return import_module("score4.api")
    if name in _PUBLIC:
        value = getattr(import_module(_PUBLIC[name]), name)
        globals()[name] = value  # later lookups skip this function
        return value
    raise AttributeError(f"module 'score4' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(__all__)
