"""The SRIM reference tables in docs/data cannot go stale: rows are recomputed with lunasrim.

Written by ``tools/figures/srim_reference_table.py``; SRIM's analytic range table is fast (tens of
ms per row), so a few rows are recomputed here from the composition and density in the file.
TRIM Monte Carlo columns are checked for consistency with the table (they take seconds per
row to recompute, so they are not rerun here).
"""

from __future__ import annotations

import csv
from pathlib import Path

import pytest

from score4.ions.composition import Composition
from score4.ions.srim_reference import stopping_table_reference

DATA = Path(__file__).resolve().parents[1] / "docs" / "data"


def _rows(name: str) -> list[dict]:
    with open(DATA / name, newline="") as fh:
        return list(csv.DictReader(line for line in fh if not line.startswith("#")))


def _composition(row: dict) -> Composition:
    atoms = tuple((s, float(f)) for s, f in (p.split(":") for p in row["atoms"].split(";")))
    return Composition(row["geant4_material"], atoms, float(row["density_g_cm3"]))


def test_reference_table_complete():
    rows = _rows("srim_reference.csv")
    cases = {(r["ion"], r["energy_keV"], r["material"]) for r in rows}
    assert len(rows) == len(cases) == 36
    assert {r["material"] for r in rows} == {"Si", "Ge", "Cu", "CaWO4", "TeO2", "NaI"}
    assert {(r["ion"], r["energy_keV"]) for r in rows} == {
        ("Pb-206", "50"), ("Pb-206", "103.144"), ("Pb-206", "200"),
        ("alpha", "1000"), ("alpha", "3000"), ("alpha", "5300"),
    }  # fmt: skip
    g4 = {r["material"]: (r["geant4_material"], r["density_g_cm3"]) for r in rows}
    assert g4["Si"] == ("G4_Si", "2.33")
    assert g4["CaWO4"] == ("G4_CALCIUM_TUNGSTATE", "6.062")
    assert g4["TeO2"] == ("materials: TeO2", "6.02")
    assert g4["NaI"][0] == "G4_SODIUM_IODIDE"


@pytest.mark.parametrize(
    ("ion", "energy_kev", "material"),
    [
        ("Pb-206", "103.144", "Si"),
        ("Pb-206", "50", "CaWO4"),
        ("Pb-206", "200", "TeO2"),
        ("alpha", "5300", "NaI"),
        ("alpha", "1000", "Ge"),
    ],
)
def test_table_rows_match_lunasrim(ion, energy_kev, material):
    (row,) = [
        r
        for r in _rows("srim_reference.csv")
        if (r["ion"], r["energy_keV"], r["material"]) == (ion, energy_kev, material)
    ]
    ref = stopping_table_reference(ion.replace("-", ""), float(energy_kev) / 1e3, _composition(row))
    for key, column in (
        ("projected_range_nm", "table_range_nm"),
        ("straggling_nm", "table_straggling_nm"),
        ("lateral_nm", "table_lateral_nm"),
    ):
        assert float(row[column]) == pytest.approx(ref[key], rel=1e-5), column


def test_trim_columns_agree_with_the_table():
    # TRIM's Monte Carlo and SRIM's table are two calculations of the same physics. Measured
    # (lunasrim 1.0.0): mean ranges agree within 6 % in every row, lateral straggling within
    # 15 %, longitudinal straggling within 15 % for Pb-206; for MeV alphas the table's
    # longitudinal straggling is 1.1-3.5 times TRIM's (TRIM is the reference to use there).
    for row in _rows("srim_reference.csv"):
        assert int(row["trim_ions"]) >= 500
        table, trim = float(row["table_range_nm"]), float(row["trim_range_nm"])
        assert trim == pytest.approx(table, rel=0.10), row
        lateral = float(row["trim_lateral_nm"]) / float(row["table_lateral_nm"])
        assert 0.8 < lateral < 1.25, row
        straggling = float(row["trim_straggling_nm"]) / float(row["table_straggling_nm"])
        if row["ion"] == "Pb-206":
            assert 0.8 < straggling < 1.25, row
        else:
            assert 0.25 < straggling <= 1.0, row


def test_thin_layer_table_complete():
    rows = _rows("srim_thin_layers.csv")
    assert len(rows) == 72
    for row in rows:
        f = float(row["transmitted_fraction"])
        assert 0 <= f <= 1
        if f > 0:
            assert 0 < float(row["mean_exit_energy_keV"]) < float(row["energy_keV"])
    si = {
        (r["ion"], r["thickness_nm"], r["angle_deg"]): float(r["transmitted_fraction"])
        for r in rows
        if r["material"] == "Si"
    }
    # thicker layers and oblique incidence let fewer ions through
    assert si[("Pb-206", "10", "0")] >= si[("Pb-206", "40", "0")]
    assert si[("Pb-206", "20", "0")] >= si[("Pb-206", "20", "60")]
    assert si[("alpha", "5000", "0")] == 1.0
