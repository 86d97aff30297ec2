"""score4: radioactive contamination on and below rough surfaces, simulated with Geant4.

The public face of the package, the few entry points a user needs::

    import score4

    config = score4.load_config("examples/paper_a_rough.yaml")  # a run configuration
    plan = score4.plan_run(config)                              # resolved once: world, source, seed
    score4.run(plan, "out/rough.h5", jobs=2)                    # simulate (Geant4 in workers)
    results = score4.read_results("out/rough.h5")               # per-event deposits, primaries

* configuration: :func:`load_config`, :class:`RunConfig`;
* planning and running: :func:`plan_run`, :class:`RunPlan`, :func:`run`;
* results: :func:`read_results`, :class:`Results`;
* surfaces: :func:`build_surface`, :class:`Surface`, :func:`load_surface`, :func:`save_surface`;
* score4 in your own geant4_pybind application: the module :mod:`score4.api`;
* errors: :class:`Score4Error` (every failure a user can cause), :class:`ConfigError` (bad input).

Every name is imported on first use (module ``__getattr__``), so ``import score4`` is cheap and
never imports Geant4: only the worker processes of a run do. Everything else in the package
(``score4.sim``, ``score4.geometry``, ``score4.world.scene``, ...) is internal: its names may change
between versions (docs/architecture.md describes the packages).
"""

from __future__ import annotations

import importlib
import os as _os
import sys as _sys
from typing import TYPE_CHECKING, Any

if _sys.argv and _os.path.basename(_sys.argv[0]) == "score4":
    # the console script: a Ctrl-C while the command imports is one line, not a traceback
    from .cli import quiet_interrupts as _quiet

    _quiet()

# public name -> (module, attribute); attribute None: the module itself
_PUBLIC: dict[str, tuple[str, str | None]] = {
    "load_config": ("score4.inputs.config", "load_config"),
    "RunConfig": ("score4.inputs.config", "RunConfig"),
    "plan_run": ("score4.runner.run_plan", "plan_run"),
    "RunPlan": ("score4.runner.run_plan", "RunPlan"),
    "run": ("score4.runner.engine", "run"),
    "read_results": ("score4.runner.output", "read_results"),
    "Results": ("score4.runner.output", "Results"),
    "build_surface": ("score4.surface.spec", "build_surface"),
    "Surface": ("score4.surface.spec", "Surface"),
    "load_surface": ("score4.surface.store", "load_surface"),
    "save_surface": ("score4.surface.store", "save_surface"),
    "api": ("score4.api", None),
    "Score4Error": ("score4.errors", "Score4Error"),
    "ConfigError": ("score4.errors", "ConfigError"),
}

__all__ = [  # exactly the keys of _PUBLIC and __version__ (tests/test_public_api.py)
    "ConfigError",
    "Results",
    "RunConfig",
    "RunPlan",
    "Score4Error",
    "Surface",
    "__version__",
    "api",
    "build_surface",
    "load_config",
    "load_surface",
    "plan_run",
    "read_results",
    "run",
    "save_surface",
]

if TYPE_CHECKING:  # for type checkers and IDEs; at run time the names come from __getattr__
    __version__: str
    from score4.inputs.config import RunConfig, load_config
    from score4.runner.engine import run
    from score4.runner.output import Results, read_results
    from score4.runner.run_plan import RunPlan, plan_run

    from . import api
    from .errors import ConfigError, Score4Error
    from .surface.spec import Surface, build_surface
    from .surface.store import load_surface, save_surface


def __getattr__(name: str) -> Any:
    if name == "__version__":  # importlib.metadata costs more than the rest of the import
        from .version import package_version

        globals()[name] = found = package_version()
        return found
    try:
        module, attribute = _PUBLIC[name]
    except KeyError:
        raise AttributeError(f"module 'score4' has no attribute {name!r}") from None
    value: Any = importlib.import_module(module)
    if attribute is not None:
        value = getattr(value, attribute)
    globals()[name] = value  # the next look-up does not come here
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
