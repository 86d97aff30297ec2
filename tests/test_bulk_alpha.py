"""Analytic anchor: a thick bulk alpha emitter sends A rho R / 4 alphas per area and time out.

A silicon slab (100 um thick, much thicker than the 27 um range of a 5.304 MeV alpha) holds
vertices drawn uniformly in its volume with isotropic alphas (a vertex file written here with
numpy: the bulk source of the configuration, ``source.volume``, is another branch's work). With
straight tracks, the alphas that leave through the top face per unit area and time are
``A rho R / 4`` (``A`` the specific activity, ``rho`` the density, ``R`` the range along the
track). A silicon detector lies on that face; its template (total activity ``A m_slab``) must give
``A rho R S / 4 * 86400 / m_det`` counts/(kg day).

``R``: the CSDA range integrated from SRIM-2013's stopping powers (lunasrim), in mass thickness,
times Geant4's silicon density: a reference nobody here wrote. Tolerance: 3 standard deviations
of the escaping count plus 4 % (Geant4's alpha stopping agrees with SRIM's to ~3 % in Si,
docs/physics.md; alphas that reach a side face first are lost, a ~0.5 % effect for a 6 mm
slab). The production cut is 10 um: the largest delta electron a 5.3 MeV alpha can knock out
(4 m_e / m_alpha x E = 2.9 keV) is below its energy threshold, so only alphas reach the detector.
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


def run_slab(tmp_path, n: int, seed: int) -> tuple[int, dict]:
    rng = np.random.default_rng(seed)
    pos = np.column_stack(
        [
            rng.uniform(-SIDE / 2, SIDE / 2, n),
            rng.uniform(-SIDE / 2, SIDE / 2, n),
            rng.uniform(-THICK, 0, n),
        ]
    )
    cos = rng.uniform(-1, 1, n)
    phi = rng.uniform(0, 2 * np.pi, n)
    sin = np.sqrt(1 - cos**2)
    direction = np.column_stack([sin * np.cos(phi), sin * np.sin(phi), cos])
    p = Primaries(np.arange(n), np.full(n, "alpha"), np.full(n, ENERGY), pos, direction)
    vertices = tmp_path / "bulk.h5"
    write_vertex_file(vertices, p, {}, seed)  # no configuration: nothing says what volume it fills
    cfg = tmp_path / "slab.yaml"
    cfg.write_text(
        yaml.safe_dump(
            {
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
                "source": {"vertices": str(vertices)},
                "run": {"events": n, "seed": seed},
            }
        )
    )
    out = tmp_path / "slab.h5"
    assert main(["-q", "run", str(cfg), "--out", str(out), "--jobs", "2"]) == 0
    return out


def check_escape_rate(tmp_path, capsys, n: int) -> None:
    results = run_slab(tmp_path, n, seed=21)
    specific = 1.0  # Bq/kg
    m_slab = RHO * SIDE * SIDE * THICK * 1e-6  # kg
    m_det = RHO * SIDE * SIDE * DET * 1e-6
    # hand-made vertices: only a total activity means something
    assert (
        main(["template", str(results), "--activity", "1 Bq/kg", "--out", str(tmp_path / "x.h5")])
        == 2
    )
    assert "total activity" in capsys.readouterr().err
    out = tmp_path / "t.h5"
    assert (
        main(
            [
                "template",
                str(results),
                "--activity",
                f"{specific * m_slab!r} Bq",
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
    det = json.loads(capsys.readouterr().out)["detectors"]["detector"]
    r_mm = srim_csda_range_mm()
    # A rho R / 4 per area and second, in kg/mm3 and mm: alphas per mm2 per s
    per_area = specific * RHO * 1e-6 * r_mm / 4
    expected = per_area * SIDE * SIDE * 86400 / m_det  # counts/(kg day)
    n_escaped = det["simulated_counts"]
    sigma = expected / np.sqrt(n * r_mm / (4 * THICK))  # Poisson error of the expected count
    rate = det["counts_per_kg_day"]
    said = (
        f"escaped {n_escaped} of {n}; rate {rate:.6g} vs A rho R/4: {expected:.6g} "
        f"counts/(kg day), ratio {rate / expected:.4f} +- {sigma / expected:.4f} "
        f"(R = {r_mm * 1e3:.3f} um)"
    )
    print(said)
    assert abs(rate - expected) < 3 * sigma + 0.04 * expected, said


def test_bulk_alpha_emitter_escape_rate_is_a_rho_r_over_4(tmp_path, capsys):
    check_escape_rate(tmp_path, capsys, 12_000)


@pytest.mark.deep
def test_bulk_alpha_emitter_escape_rate_deep(tmp_path, capsys):
    check_escape_rate(tmp_path, capsys, 200_000)
