"""read_topography on a Sensofar .plu file, checked against an independent reader.

No real .plu file with a redistributable licence was found in any reachable package (checked:
SurfaceTopography 1.27.1 sdist and wheel, which exclude their samples; surfalize 0.10.2 sdist
and 0.19.2 wheel; pluxtools 0.1.0), so tests/data/topography/synthetic_40x30.plu is SYNTHETIC:
a known height map packed by tests/data/topography/make_synthetic_plu.py into the layout that
SurfaceTopography's PLUReader and Gwyddion's sensofar module read (both say: after the header
blocks, each layer starts with uint32 rows, uint32 columns, then the float32 heights).

The reference figures below were obtained by reading that file with SurfaceTopography 1.27.1
in a scratch venv (``make_synthetic_plu.py --reference``); SurfaceTopography is not a score4
dependency.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from score4.surface.readers import read_topography

PLU = Path(__file__).parent / "data" / "topography" / "synthetic_40x30.plu"
UM = 1e-3  # mm

# SurfaceTopography 1.27.1 PLUReader on synthetic_40x30.plu (its arrays are (x, y); here (row=y, col=x)):
# nb_grid_pts (40, 30), physical_sizes (33.19999933, 37.5) um, one masked point at x=11, y=7,
# mean 0.825505599 um, std 0.711734515 um, h[0, 0] = -0.065179117, h[39, 29] = 1.59465361,
# h[5, 3] = 0.900684297 um.
REF_SHAPE = (30, 40)
REF_PITCH_UM = (33.19999933242798 / 40, 37.5 / 30)
REF_MISSING = (7, 11)
REF_MEAN_UM, REF_STD_UM = 0.825505599, 0.711734515
REF_POINTS_UM = {(0, 0): -0.065179117, (29, 39): 1.59465361, (3, 5): 0.900684297}


def test_plu_grid_and_pitch_match_surfacetopography():
    hm = read_topography(PLU)
    assert hm.shape == REF_SHAPE
    assert hm.pitch_x == pytest.approx(REF_PITCH_UM[0] * UM, rel=1e-7)
    assert hm.pitch_y == pytest.approx(REF_PITCH_UM[1] * UM, rel=1e-7)
    assert hm.metadata["format"] == "plu"


@pytest.mark.xfail(strict=True, reason=(
    "surfalize 0.19.2 (score4's .plu backend) does not skip the layer's 8-byte rows/columns header: "
    "heights start 2 samples early (first two are the integers 30 and 40 read as float32, ~4e-44), "
    "the whole map is shifted by 2 columns and the unmeasured point lands at (7, 13)"))
def test_plu_heights_match_surfacetopography():
    hm = read_topography(PLU)
    missing = np.argwhere(np.isnan(hm.heights)).tolist()
    assert missing == [list(REF_MISSING)]
    for (row, col), value in REF_POINTS_UM.items():
        assert hm.heights[row, col] == pytest.approx(value * UM, rel=1e-6)
    assert np.nanmean(hm.heights) == pytest.approx(REF_MEAN_UM * UM, rel=1e-6)
    assert np.nanstd(hm.heights) == pytest.approx(REF_STD_UM * UM, rel=1e-6)
