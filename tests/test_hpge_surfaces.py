"""HPGe surface groups (pplus, passive, nplus) from LEGEND metadata: score4.shapes.hpge against
legend-pygeom-hpges' own surface names, on the detector types it builds."""

from __future__ import annotations

import copy

import numpy as np
import pytest

from score4.shapes import G4GenericPolycone
from score4.shapes.hpge import hpge_groups

from helpers.gdml_worlds import BEGE

pytest.importorskip("pygeomhpges")

_TAPER0 = {"top": {"angle_in_deg": 0.0, "height_in_mm": 0.0}}
ICPC = {
    "name": "V00000A",
    "type": "icpc",
    "production": {"enrichment": 0.88},
    "geometry": {
        "height_in_mm": 80.0,
        "radius_in_mm": 38.0,
        "borehole": {"radius_in_mm": 5.0, "depth_in_mm": 55.0},
        "groove": {"depth_in_mm": 2.0, "radius_in_mm": {"outer": 12.0, "inner": 9.0}},
        "pp_contact": {"radius_in_mm": 4.0, "depth_in_mm": 1.0},
        "taper": {
            "top": {"angle_in_deg": 45.0, "height_in_mm": 5.0},
            "bottom": {"angle_in_deg": 0.0, "height_in_mm": 0.0},
            "borehole": {"angle_in_deg": 0.0, "height_in_mm": 0.0},
        },
    },
}
PPC = {
    "name": "P00000A",
    "type": "ppc",
    "production": {"enrichment": 0.88},
    "geometry": {
        "height_in_mm": 40.0,
        "radius_in_mm": 30.0,
        "pp_contact": {"radius_in_mm": 1.5, "depth_in_mm": 0.0},
        "taper": {
            "top": {"angle_in_deg": 30.0, "height_in_mm": 3.0},
            "bottom": {"angle_in_deg": 45.0, "height_in_mm": 2.0},
        },
    },
}
COAX = {
    "name": "C000RG1",
    "type": "coax",
    "production": {"enrichment": 0.88},
    "geometry": {
        "height_in_mm": 70.0,
        "radius_in_mm": 38.0,
        "borehole": {"radius_in_mm": 7.0, "depth_in_mm": 50.0},
        "groove": {"depth_in_mm": 2.0, "radius_in_mm": {"outer": 20.0, "inner": 15.0}},
        "taper": {
            "top": {"angle_in_deg": 45.0, "height_in_mm": 3.0},
            "bottom": {"angle_in_deg": 45.0, "height_in_mm": 3.0},
            "borehole": {"angle_in_deg": 10.0, "height_in_mm": 10.0},
        },
    },
}


def _variants():
    deep = copy.deepcopy(BEGE)
    deep["geometry"]["pp_contact"]["depth_in_mm"] = 1.0
    wide = copy.deepcopy(BEGE)
    wide["geometry"]["pp_contact"]["radius_in_mm"] = 10.0  # contact out to the groove
    well = copy.deepcopy(PPC)
    well["geometry"]["pp_contact"]["depth_in_mm"] = 1.0
    flat = copy.deepcopy(ICPC)
    flat["geometry"]["pp_contact"]["depth_in_mm"] = 0.0
    return {
        "bege": BEGE,
        "bege_deep_contact": deep,
        "bege_contact_to_groove": wide,
        "icpc": ICPC,
        "icpc_flat_contact": flat,
        "ppc": PPC,
        "ppc_well": well,
        "coax": COAX,
    }


def _reference(meta):
    """legend-pygeom-hpges' contour (r, z) and its surface name per edge."""
    import pyg4ometry as pg
    from pygeomhpges import make_hpge

    det = make_hpge(meta, registry=pg.geant4.Registry())
    r, z = det._decode_polycone_coord()
    return np.column_stack([r, z]), list(det.surfaces)


def _reference_label(poly, names, point):
    """The name of the reference edge holding ``point`` (r, z)."""
    a, b = poly[:-1], poly[1:]
    d = b - a
    length = np.hypot(d[:, 0], d[:, 1])
    keep = length > 0
    t = np.einsum("ij,ij->i", point - a[keep], d[keep]) / length[keep] ** 2
    off = np.abs((point[0] - a[keep, 0]) * d[keep, 1] - (point[1] - a[keep, 1]) * d[keep, 0])
    hit = np.flatnonzero((off / length[keep] < 1e-9) & (t > 0) & (t < 1))
    assert len(hit) == 1, point
    return np.asarray(names)[keep][hit[0]]


@pytest.mark.parametrize("case", list(_variants()))
def test_groups_match_legend_pygeom_hpges(case):
    meta = _variants()[case]
    poly, names = _reference(meta)
    shape = hpge_groups(
        G4GenericPolycone(0.0, 2 * np.pi, tuple(poly[:, 0]), tuple(poly[:, 1])), meta
    )
    groups = shape.groups
    labelled = {f: g for g in ("pplus", "passive", "nplus") for f in groups.get(g, ())}
    assert set(labelled) == set(shape.faces)  # every face in exactly one of the three
    assert sum(len(groups.get(g, ())) for g in ("pplus", "passive", "nplus")) == len(shape.faces)
    contour, edge_names = shape.contour()
    for i, face in enumerate(edge_names):
        if not face:
            continue
        mid = 0.5 * (contour[i] + contour[(i + 1) % len(contour)])
        assert labelled[face] == _reference_label(poly, names, mid), (case, face)
    # the areas of the groups: legend-pygeom-hpges' own surface areas per name
    for g in ("pplus", "passive", "nplus"):
        rows = [k for k, n in enumerate(names) if n == g]
        a, b = poly[rows], poly[[k + 1 for k in rows]]
        expected = np.sum(np.pi * (a[:, 0] + b[:, 0]) * np.hypot(*(b - a).T))
        assert shape.face_area(g) == pytest.approx(expected, rel=1e-9) if rows else g not in groups


def test_bege_contact_and_ring_are_separate_faces():
    poly, _ = _reference(BEGE)
    plain = G4GenericPolycone(0.0, 2 * np.pi, tuple(poly[:, 0]), tuple(poly[:, 1]))
    shape = hpge_groups(plain, BEGE)
    assert "seg_0" in plain.faces
    assert "seg_0" not in shape.faces
    assert shape.groups["seg_0"] == ("seg_0a", "seg_0b")
    assert shape.groups["pplus"] == ("seg_0a",)
    assert shape.face_area("seg_0a") == pytest.approx(np.pi * 7.5**2, rel=1e-12)
    assert shape.face_area("seg_0") == pytest.approx(plain.face_area("seg_0"), rel=1e-12)
    assert [f for f in shape.faces if not f.startswith("seg_0")] == list(plain.faces[1:])
    assert shape.area == pytest.approx(plain.area, rel=1e-12)
