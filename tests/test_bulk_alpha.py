"""Analytic anchor: a thick bulk alpha emitter sends A rho R / 4 alphas per area and time out.

A silicon slab (100 um thick, much thicker than the 27 um range of a 5.304 MeV alpha) is a bulk
source (``source.volume``: vertices uniform in it, isotropic alphas). With straight tracks, the
alphas that leave through its top face per unit area and time are ``A rho R / 4`` (``A`` the
specific activity, ``rho`` the density, ``R`` the range along the track). A silicon detector lies
on that face; its template for ``A`` = 1 Bq/kg must give ``A rho R S / 4 * 86400 / m_det``
counts/(kg day) (``S`` the face area).

``R``: the CSDA range integrated from SRIM-2013's stopping powers (lunasrim), in mass thickness,
divided by Geant4's silicon density: a reference nobody here wrote. Tolerance: 3 standard
deviations of the escaping count plus 4 % (Geant4's alpha stopping agrees with SRIM's to ~3 % in
Si, docs/physics.md; alphas that reach a side face first are lost, a ~0.5 % effect for a 6 mm
slab; multiple scattering bends tracks a little). The production cut is 10 um: the largest delta
electron a 5.3 MeV alpha can knock out (4 m_e / m_alpha x E = 2.9 keV) is below its energy
threshold, so only alphas reach the detector.

The same emitters as a hand-made vertex file (numpy, no configuration stored): only a total
activity in Bq applies to it.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
import yaml

from score4.cli.main import main
from score4.source.primaries import Primaries
from score4.source.vertex_file import write_vertex_file

ENERGY = 5.30433  # MeV, the Po-210 alpha (ENSDF)
RHO = 2.33  # g/cm3, Geant4's G4_Si
SIDE, THICK, DET = 6.0, 0.1, 0.05  # mm


def srim_csda_range_mm() -> float:
    """CSDA range of the alpha in silicon from SRIM's stopping (electronic + nuclear)."""
    lunasrim = pytest.importorskip("lunasrim")
    rows = np.array(
        lunasrim.stopping_table(
            "He", {"Si": 1.0}, emin=1.0, emax=ENERGY * 1e3, units="MeV/(mg/cm2)"
        )
    )
    e_mev, s = rows[:, 0] * 1e-3, rows[:, 1] + rows[:, 2]
    mass_range = np.trapezoid(1.0 / s, e_mev) + e_mev[0] / s[0]  # mg/cm2 (below 1 keV: ~0.1 %)
    return mass_range * 1e-3 / RHO * 10  # mg/cm2 -> g/cm2 -> cm -> mm


def slab_config(source: dict, n: int, seed: int) -> dict:
    return {
        "physics": {"mode": "lite", "production_cut": "10 um"},
        "targets": [
            {
                "name": "slab",
                "material": "G4_Si",
                "size": [f"{SIDE} mm", f"{SIDE} mm", f"{THICK} mm"],
                "position": ["0 mm", "0 mm", f"{-THICK / 2} mm"],
            },
            {
                "name": "detector",
                "material": "G4_Si",
                "size": [f"{SIDE} mm", f"{SIDE} mm", f"{DET} mm"],
                "position": ["0 mm", "0 mm", f"{DET / 2} mm"],
            },
        ],
        "source": source,
        "run": {"events": n, "seed": seed},
    }


def run(tmp_path, data: dict):
    cfg = tmp_path / "slab.yaml"
    cfg.write_text(yaml.safe_dump(data))
    out = tmp_path / "slab.h5"
    assert main(["-q", "run", str(cfg), "--out", str(out), "--jobs", "2"]) == 0
    return out


def check_escape_rate(tmp_path, capsys, n: int) -> None:
    bulk = {"volume": "slab", "particle": "alpha", "energy": f"{ENERGY} MeV"}
    results = run(tmp_path, slab_config(bulk, n, seed=21))
    capsys.readouterr()  # the run's own report
    m_det = RHO * SIDE * SIDE * DET * 1e-6  # kg
    out = tmp_path / "t.h5"
    assert (
        main(
            [
                "template",
                str(results),
                "--activity",
                "1 Bq/kg",
                "--detector",
                "detector",
                "--emax",
                "6 MeV",
                "--out",
                str(out),
                "--json",
            ]
        )
        == 0
    )
    report = json.loads(capsys.readouterr().out)
    det = report["detectors"]["detector"]
    # the activity multiplies the slab's mass: 1 Bq/kg x 6 x 6 x 0.1 mm3 of silicon
    assert report["activity"]["total_Bq"] == pytest.approx(RHO * SIDE * SIDE * THICK * 1e-6)
    r_mm = srim_csda_range_mm()
    per_area = 1.0 * RHO * 1e-6 * r_mm / 4  # A rho R / 4: Bq/kg * kg/mm3 * mm = 1/(mm2 s)
    expected = per_area * SIDE * SIDE * 86400 / m_det  # counts/(kg day)
    sigma = expected / np.sqrt(n * r_mm / (4 * THICK))  # Poisson error of the expected count
    rate = det["counts_per_kg_day"]
    said = (
        f"escaped {det['simulated_counts']} of {n}; rate {rate:.6g} vs A rho R/4: {expected:.6g} "
        f"counts/(kg day), ratio {rate / expected:.4f} +- {sigma / expected:.4f} "
        f"(R = {r_mm * 1e3:.3f} um)"
    )
    print(said)
    assert abs(rate - expected) < 3 * sigma + 0.04 * expected, said
    # a per-area activity does not fit a bulk source
    assert (
        main(
            ["template", str(results), "--activity", "1 mBq/cm2", "--out", str(out), "--overwrite"]
        )
        == 2
    )
    assert "fills the volume slab" in capsys.readouterr().err


def test_bulk_alpha_emitter_escape_rate_is_a_rho_r_over_4(tmp_path, capsys):
    check_escape_rate(tmp_path, capsys, 12_000)


@pytest.mark.deep
def test_bulk_alpha_emitter_escape_rate_deep(tmp_path, capsys):
    check_escape_rate(tmp_path, capsys, 200_000)


def test_hand_made_vertex_file_takes_a_total_activity(tmp_path, capsys):
    n = 200
    rng = np.random.default_rng(5)
    pos = np.column_stack([rng.uniform(-1, 1, (n, 2)), rng.uniform(-0.02, 0, n)])  # <= 20 um deep
    p = Primaries(
        np.arange(n), np.full(n, "alpha"), np.full(n, ENERGY), pos, np.tile([0.0, 0.0, 1.0], (n, 1))
    )
    vertices = tmp_path / "v.h5"
    write_vertex_file(vertices, p, {}, 5)  # no configuration: nothing says what volume it fills
    results = run(tmp_path, slab_config({"vertices": str(vertices)}, n, 5))
    capsys.readouterr()
    out = tmp_path / "t.h5"
    assert main(["template", str(results), "--activity", "1 Bq/kg", "--out", str(out)]) == 2
    assert "total activity" in capsys.readouterr().err
    assert not out.exists()
    assert main(["template", str(results), "--activity", "2 Bq", "--out", str(out), "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["activity"]["total_Bq"] == 2.0
    # straight up from at most 20 um deep (the range is 27 um): every alpha reaches the detector
    det = report["detectors"]["detector"]
    assert det["simulated_counts"] == n
    assert det["counts_per_kg_day"] == pytest.approx(2.0 * 86400 / (RHO * SIDE**2 * DET * 1e-6))
