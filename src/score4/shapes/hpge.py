"""The surfaces of a LEGEND HPGe detector (``pplus``, ``passive``, ``nplus``) from its metadata.

LEGEND describes each germanium detector by a metadata entry (``type``: bege, icpc, ppc, coax;
``geometry``: height, radius, p+ contact, groove, borehole, tapers, in mm), and
legend-pygeom-hpges builds the detector from it as a G4GenericPolycone. legend-pygeom-tools
writes the entry into the GDML file's ``<userinfo>`` (auxiliary ``RMG_detector_meta``, JSON per
physical volume), which score4 reads with the world (:mod:`score4.world.gdml_model`).

From the entry, :func:`hpge_groups` gives the detector's polycone

- *cuts* where one contour edge holds two surfaces: on a BEGe or ICPC with a flat p+ contact,
  the bottom disk ``seg_0`` is the p+ contact (r < pp_contact radius) and the passivated ring
  out to the groove; they become the faces ``seg_0a`` and ``seg_0b`` (the group ``seg_0``);
- *labels*: the group ``pplus`` (the p+ contact), ``passive`` (the passivated surface: the
  groove and, where there is one, the ring between contact and groove) and ``nplus`` (the
  lithium-diffused rest), by where each face lies: the rules of LEGEND's detector types, as
  legend-pygeom-hpges assigns them (``HPGe.surfaces``; the tests compare the two).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from .revolved import G4GenericPolycone, _edges

#: LEGEND detector types whose surfaces score4 names.
HPGE_TYPES = ("bege", "icpc", "ppc", "coax")
#: The surface groups a detector's metadata give.
HPGE_GROUPS = ("pplus", "passive", "nplus")

_EPS = 1e-6  # mm


def _number(node: Any, *keys: str, default: float = 0.0) -> float:
    for key in keys:
        if not isinstance(node, Mapping) or key not in node:
            return default
        node = node[key]
    try:
        return float(node)
    except (TypeError, ValueError):
        return default


def is_hpge_metadata(meta: object) -> bool:
    """True for a LEGEND HPGe metadata entry of a type :func:`hpge_groups` handles."""
    return (
        isinstance(meta, Mapping)
        and meta.get("type") in HPGE_TYPES
        and isinstance(meta.get("geometry"), Mapping)
    )


def _label(kind: str, g: Mapping, rm: float, zm: float, nr: float, nz: float) -> str:
    """The surface of a contour edge with midpoint (rm, zm) and outward normal (nr, nz)."""
    rp = _number(g, "pp_contact", "radius_in_mm")
    dp = _number(g, "pp_contact", "depth_in_mm")
    gi = _number(g, "groove", "radius_in_mm", "inner")
    go = _number(g, "groove", "radius_in_mm", "outer")
    gd = _number(g, "groove", "depth_in_mm")
    flat = abs(nr) <= 1e-12
    if kind == "coax":  # p+ is the borehole from the bottom and the ring out to the groove
        bd = _number(g, "borehole", "depth_in_mm")
        if rm < gi - _EPS and zm <= bd + _EPS:
            return "pplus"
        if gi - _EPS <= rm <= go + _EPS and zm <= gd + _EPS:
            return "passive"
        return "nplus"
    if flat and nz < 0 and abs(zm - dp) <= _EPS and rm < rp:
        return "pplus"  # the contact: the disk at its depth
    if kind == "ppc":  # the whole bottom outside the contact (and the contact's well wall)
        if (flat and nz < 0 and abs(zm) <= _EPS) or (abs(rm - rp) <= _EPS and zm <= dp + _EPS):
            return "passive"
        return "nplus"
    if rm <= go + _EPS and zm <= max(gd, dp) + _EPS:  # bege, icpc: groove and inner ring
        return "passive"
    return "nplus"


def hpge_groups(shape: G4GenericPolycone, meta: Mapping) -> G4GenericPolycone:
    """``shape`` (the detector's polycone, in the frame legend-pygeom-hpges builds it: the p+
    side at z = 0) with the cuts and the ``pplus`` / ``passive`` / ``nplus`` labels of its
    metadata entry ``meta`` (see the module docstring)."""
    g = meta["geometry"]
    kind = str(meta["type"])
    candidates = [
        (_number(g, "pp_contact", "radius_in_mm"), 0.0),
        (_number(g, "groove", "radius_in_mm", "inner"), 0.0),
        (_number(g, "groove", "radius_in_mm", "outer"), 0.0),
    ]
    poly = shape.canonical()
    a, b, _ = _edges(poly)
    cuts: list[float] = []
    for r, z in candidates:
        p = np.array([r, z])
        if r <= 0 or any(np.hypot(*(p - c)) <= _EPS for c in poly):
            continue  # no point, or a corner already
        d = b - a
        length = np.hypot(d[:, 0], d[:, 1])
        t = np.einsum("ij,ij->i", p - a, d) / length**2
        off = np.abs((p[0] - a[:, 0]) * d[:, 1] - (p[1] - a[:, 1]) * d[:, 0]) / length
        on = (off <= _EPS) & (t > 0) & (t < 1)
        if on.any() and (r, z) not in zip(cuts[::2], cuts[1::2], strict=True):
            cuts += [r, z]
    split = G4GenericPolycone(shape.sphi, shape.dphi, shape.r, shape.z, tuple(cuts))
    contour, names = split.contour()
    a, b, normal = _edges(contour)
    labels = []
    for i, name in enumerate(names):
        if not name:
            continue
        rm, zm = 0.5 * (a[i] + b[i])
        labels.append(_label(kind, g, float(rm), float(zm), *map(float, normal[i])))
    return G4GenericPolycone(shape.sphi, shape.dphi, shape.r, shape.z, tuple(cuts), tuple(labels))
