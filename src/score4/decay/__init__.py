"""Radioactive decay from evaluated data, sampled in numpy (no Geant4 data needed).

* :mod:`.data`: the shipped ENSDF decay data, atomic data and masses; nuclide names.
* :mod:`.spectra`: beta spectrum shapes.
* :mod:`.scheme`: one nuclide's decay compiled and sampled (:func:`decay_scheme`).
* :mod:`.chain`: decay chains, Bateman activities, chain events with coincidences.
"""

from .nuclear_data import ZAI, known_nuclides, nuclide_record, zai_name
from .scheme import KINDS, DecayScheme, Emissions, Line, decay_scheme, two_body_kinetic

__all__ = [
    "KINDS",
    "ZAI",
    "DecayScheme",
    "Emissions",
    "Line",
    "decay_scheme",
    "known_nuclides",
    "nuclide_record",
    "two_body_kinetic",
    "zai_name",
]
