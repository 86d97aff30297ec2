"""The command tables: which original SCoRe4 / Geant4 commands set which parameter, which are
ignored on purpose and why, and the original's defaults.
"""

from __future__ import annotations

from .reader import Quantity

VERBOSE = "output verbosity only"
_VOXEL = (
    "voxel boundary cap of the original's patched G4Voxelizer; score4 builds its solids "
    "without it (docs/geant4-facts.md: solids of <= 1e5 spikes, large faces tiled)"
)
_STEP = (
    "deviation: G4UserLimits max step on the patch; score4 sets no per-volume step limit (its "
    "physics sets step functions and physics.production_cut; see the report's notes)"
)
#: RoughnessHelper::CheckValues: without setStepLimit the roughness volume gets G4UserLimits of
#: this fraction of the smaller spike half-width (acting on the ions, alpha, He3, d and t that
#: the original's physics lists give a G4StepLimiter).
DEFAULT_STEP_FRACTION = 0.01

# param, value kind; kinds: length (> 0), length0 (>= 0), count, word, spikeform
ROUGHNESS = {
    "setBasisDx": ("basis_dx", "length"),
    "setBasisDy": ("basis_dy", "length"),
    "setBasisDz": ("basis_dz", "length"),
    "setSpikeDx": ("dx", "length"),
    "setSpikeDy": ("dy", "length"),
    "setSpikeMeanHeight": ("mean", "length"),
    "setSpikeDevHeight": ("dev", "length0"),
    "setSpikeform": ("form", "spikeform"),
    "setNLayer": ("nlayer", "count"),
    "setSpikesNx": ("nx", "count"),
    "setSpikesNy": ("ny", "count"),
    "setMaterial": ("material", "word"),
}
ROUGHNESS_IGNORED = {
    "setVerbose": VERBOSE,
    "setBoundaryNx": _VOXEL,
    "setBoundaryNy": _VOXEL,
    "setBoundaryNz": _VOXEL,
    "setStepLimit": _STEP,
}
PORTAL = {
    "setDxPortal": ("dx", "length"),
    "setDyPortal": ("dy", "length"),
    "setDzPortal": ("dz", "length"),
    "setDxSubworld": ("sub_dx", "length"),
    "setDySubworld": ("sub_dy", "length"),
    "setDzSubworld": ("sub_dz", "length"),
    "setNxSubworld": ("nx", "count"),
    "setNySubworld": ("ny", "count"),
    "setMaterial": ("material", "word"),
}
PORTAL_IGNORED = {"setVerbose": VERBOSE}
DESCRIBER = {
    "setSpikeWidth_X": ("dx", "length"),
    "setSpikeWidth_Y": ("dy", "length"),
    "setNrSpike_X": ("nx", "count"),
    "setNrSpike_Y": ("ny", "count"),
    "setMeanHeight": ("mean", "length"),
    "setHeightDeviation": ("dev", "length0"),
    "setSpikeform": ("form", "describer_form"),
    "setNLayer": ("nlayer", "count"),
}
# DescriberParameters defaults (notes §1.1 and §1.8); lengths are half-lengths in mm.
DESCRIBER_DEFAULTS = {
    "dx": "0.005 mm",
    "dy": "0.005 mm",
    "nx": 1,
    "ny": 1,
    "mean": "0.005 mm",
    "dev": "1 mm",
    "form": "StandardPyramid",
    "nlayer": 1,
}
DEFAULT_DESCRIBER_WIDTH = Quantity(0.005, "mm", 0.005, "length")
SPIKEFORMS = {
    "StandardPyramid": "pyramid",
    "UniformPyramid": "pyramid",
    "Bump": "bump",
    "Peak": "peak",
}

IGNORED_EXACT = {
    "/run/initialize": "score4 initialises Geant4 itself",
    "/run/printProgress": "progress output only (score4 run shows a progress bar)",
    "/run/numberOfThreads": "score4 runs events in processes: score4 run --jobs N",
    "/run/useMaximumLogicalCores": "score4 runs events in processes: score4 run --jobs N",
    "/control/saveHistory": "Geant4 session history only",
    "/control/echo": "prints text only",
    "/control/stopSavingHistory": "Geant4 session history only",
    "/tracking/storeTrajectory": "trajectories are kept for visualisation only",
    "/SurfaceSource/ShowSurface": "draws the facets (visualisation)",
    "/shift/printShiftTable": "prints the table only",
    "/gps/List": "prints the particle table only",
    "/random/setSavingFlag": "saves the engine status only",
}
IGNORED_PREFIX = {
    "/vis/": "visualisation",
    "/analysis/": "histogram/ntuple files of the original example; score4 writes its own results "
    "file",
    "/control/cout/": "output redirection only",
    "/gps/pos/": "the original's sampler overwrites the GPS position with a point on the rough "
    "surface; score4 samples on the rough face itself",
    "/gps/ang/rot": "only turns the frame of the angular distribution; the converted one (iso) has "
    "no frame",
}
GPS_POSITION = {
    "/gps/position",
    "/gps/centre",
    "/gps/type",
    "/gps/shape",
    "/gps/halfx",
    "/gps/halfy",
    "/gps/halfz",
    "/gps/radius",
    "/gps/radius0",
    "/gps/posrot1",
    "/gps/posrot2",
    "/gps/confine",
}
