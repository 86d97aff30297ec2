"""read_topography on a Sensofar .plu file, checked against an independent reader.

No real .plu file with a redistributable licence was found in any reachable package (checked:
SurfaceTopography 1.27.1 sdist and wheel, which exclude their samples; surfalize 0.10.2 sdist
and 0.19.2 wheel; pluxtools 0.1.0), so tests/data/topography/synthetic_40x30.plu is SYNTHETIC:
a known height map packed by tests/data/topography/make_synthetic_plu.py into the layout that
SurfaceTopography's PLUReader and Gwyddion's sensofar module read (both say: after the header
blocks, each layer starts with uint32 rows, uint32 columns, then the float32 heights).

The reference figures below were obtained by reading that file with SurfaceTopography 1.27.1
in a scratch venv (``make_synthetic_plu.py --reference``); SurfaceTopography is not a score4
dependency. score4 reads .plu with its own reader (surfalize 0.19.2 read the heights 8 bytes early,
shifting the map by 2 columns); damaged copies of the file must be refused with a ConfigError.
"""

from __future__ import annotations

import struct
from pathlib import Path

import numpy as np
import pytest

from score4.errors import ConfigError
from score4.surface.readers import read_topography

PLU = Path(__file__).parent / "data" / "topography" / "synthetic_40x30.plu"
UM = 1e-3  # mm

# SurfaceTopography 1.27.1 PLUReader on synthetic_40x30.plu (its arrays are (x, y); here (row=y,
# col=x)): nb_grid_pts (40, 30), physical_sizes (33.19999933, 37.5) um, one masked point at x=11,
# y=7, mean 0.825505599 um, std 0.711734515 um, h[0, 0] = -0.065179117, h[39, 29] = 1.59465361, h[5,
# 3] = 0.900684297 um.
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


def test_plu_heights_match_surfacetopography():
    hm = read_topography(PLU)
    missing = np.argwhere(np.isnan(hm.heights)).tolist()
    assert missing == [list(REF_MISSING)]
    for (row, col), value in REF_POINTS_UM.items():
        assert hm.heights[row, col] == pytest.approx(value * UM, rel=1e-6)
    assert np.nanmean(hm.heights) == pytest.approx(REF_MEAN_UM * UM, rel=1e-6)
    assert np.nanstd(hm.heights) == pytest.approx(REF_STD_UM * UM, rel=1e-6)


def test_plu_metadata():
    meta = read_topography(PLU).metadata
    assert meta["date"] == "Fri Mar 10 16:35:59 2023"
    assert meta["comment"] == "score4 synthetic test file"
    assert meta["objective"] == 14
    assert meta["layers"] == 1


# Offsets in synthetic_40x30.plu: 500-byte header (grid size in the calibration block at 388, number
# of layers at byte 489), then the layer's uint32 rows, columns at 500, heights from 508.
def _damaged(tmp_path: Path, name: str, data: bytes) -> Path:
    path = tmp_path / name
    path.write_bytes(data)
    return path


def test_plu_truncated_is_refused(tmp_path):
    data = PLU.read_bytes()
    for cut, rule in (
        (len(data) - 100, "exactly 8916 bytes"),
        (508 + 4 * 600, "exactly 8916 bytes"),
        (300, "at least 508 bytes"),
    ):
        path = _damaged(tmp_path, f"cut{cut}.plu", data[:cut])
        with pytest.raises(ConfigError, match=rf"cut{cut}\.plu: .*truncated .*{rule}"):
            read_topography(path)


def test_plu_wrong_size_field_is_refused(tmp_path):
    data = bytearray(PLU.read_bytes())
    assert struct.unpack_from("<2I", data, 500) == (30, 40)
    layer = data.copy()
    struct.pack_into("<2I", layer, 500, 30, 41)  # layer says 41 columns, calibration 40
    with pytest.raises(
        ConfigError, match=r"layer\.plu: .*layer size 30 x 41 .* calibration block's 30 x 40"
    ):
        read_topography(_damaged(tmp_path, "layer.plu", bytes(layer)))
    both = data.copy()
    struct.pack_into(
        "<2I", both, 388, 30, 39
    )  # calibration and layer agree on 39 columns (file has 40):
    struct.pack_into("<2I", both, 500, 30, 39)  # the heights fit, only the file size gives it away
    with pytest.raises(ConfigError, match=r"both\.plu: .*too long .*exactly 8706 bytes"):
        read_topography(_damaged(tmp_path, "both.plu", bytes(both)))


def test_plu_unsupported_content_is_refused(tmp_path):
    data = PLU.read_bytes()
    profile = bytearray(data)
    struct.pack_into("<I", profile, 428, 1)  # measurement type 1: a profile
    with pytest.raises(ConfigError, match=r"profile\.plu: .*type 1 \(profile\) is not supported"):
        read_topography(_damaged(tmp_path, "profile.plu", bytes(profile)))
    layers = bytearray(data)
    layers[489] = 2
    with pytest.raises(ConfigError, match=r"layers\.plu: .*2 layers"):
        read_topography(_damaged(tmp_path, "layers.plu", bytes(layers)))
