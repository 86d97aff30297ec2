"""Import the original SCoRe4's Geant4 macros as score4 run configurations.

:func:`import_macro` reads a plain Geant4 macro (no ``/control/alias``) written for the
original C++ SCoRe4 and returns a score4 run configuration (a mapping that
:func:`score4.inputs.config.parse_config` accepts) together with an :class:`ImportReport` that
accounts for every command: converted (line -> config key), ignored on purpose (with the reason), or
not converted (unknown commands and values score4 cannot represent; never dropped silently).
:func:`write_config` writes the configuration as commented YAML.

The half-length rule
--------------------
The original's setters take Geant4 *half*-lengths (G4Box/G4Trd convention): spike half-widths,
basis and portal half-sizes. score4 uses full lengths everywhere, so each of them is doubled.
Heights follow the original's geometry exactly (notes §1.1 ``Spike``): a pyramid is one G4Trd
of half-height ``MeanHeight`` centred at z = ``MeanHeight``, so its full height is
**2 x setSpikeMeanHeight** (and the Gaussian sigma of UniformPyramid doubles with it); Bump
and Peak stack layers whose heights add up to ``MeanHeight``, so their full height is
**1 x setSpikeMeanHeight**.

What the macro cannot say (the original builds it in C++) is filled with stated defaults: a
target block of the patch material under the rough face, 1 mm thick, with the face at z = 0;
the face ``+z``; the source on that face. Each default is listed in the report and in the
YAML header.

Modules: :mod:`.reader` (tokens, includes, quantities, command records), :mod:`.tables` (the
command tables), :mod:`.collect` (commands -> helper parameters and settings), :mod:`.convert`
(-> the configuration; :func:`import_macro`), :mod:`.report` (:class:`ImportReport`),
:mod:`.writer` (commented YAML and the files beside it).
"""

from .collect import UNNAMED_HELPER
from .convert import DEFAULT_MATERIAL, DEFAULT_TARGET, DEFAULT_TARGET_THICKNESS, import_macro
from .report import ImportReport, ReportItem
from .writer import render_yaml, write_config

__all__ = [
    "DEFAULT_MATERIAL",
    "DEFAULT_TARGET",
    "DEFAULT_TARGET_THICKNESS",
    "UNNAMED_HELPER",
    "ImportReport",
    "ReportItem",
    "import_macro",
    "render_yaml",
    "write_config",
]
