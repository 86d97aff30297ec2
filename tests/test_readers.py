"""read_topography on files not written by score4: shipped samples of other packages (see
tests/data/topography/README.md) and files written at test time by other libraries' writers.
Each is checked against an independent reader or the documented dimensions of the file."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

from score4.errors import ConfigError
from score4.surface.readers import FORMATS, grid_from_points, read_topography

DATA = Path(__file__).parent / "data" / "topography"
UM = 1e-3  # mm


def _surfalize_raw(path: Path):
    common = pytest.importorskip("surfalize.file.common")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return common.FileHandler(path).read()


# ----------------------------------------------------------------------------- x3p
def test_x3p_matches_x3pio_and_surfalize():
    # x3pio CC0 sample: 200 x 150 points, int16 with a region of missing points, 1 um pitch
    x3pio = pytest.importorskip("x3pio")
    path = DATA / "x3pio_surface_binary.x3p"
    hm = read_topography(path)
    assert hm.shape == (150, 200)
    assert hm.pitch_x == pytest.approx(1 * UM)
    assert hm.pitch_y == pytest.approx(1 * UM)
    assert int(np.isnan(hm.heights).sum()) == 180
    ref = x3pio.read(path).layers[0].z  # metres
    np.testing.assert_allclose(hm.heights, np.asarray(ref) * 1e3, equal_nan=True)
    raw = _surfalize_raw(path)  # a second, independent implementation, in um
    np.testing.assert_allclose(hm.heights, raw.data * UM, rtol=1e-9, atol=1e-15, equal_nan=True)
    assert raw.step_x * UM == pytest.approx(hm.pitch_x)
    assert hm.metadata["format"] == "x3p"
    assert hm.metadata["source"] == str(path)


def test_x3p_opengps_sample():
    # openGPS ISO5436-sample1_bin: a 4 x 4 float64 surface with one missing point
    path = DATA / "opengps_ISO5436-sample1_bin.x3p"
    hm = read_topography(path)
    raw = _surfalize_raw(path)
    assert hm.shape == (4, 4)
    assert int(np.isnan(hm.heights).sum()) == 1
    assert hm.pitch_x == pytest.approx(raw.step_x * UM)
    np.testing.assert_allclose(hm.heights, raw.data * UM, rtol=1e-9, equal_nan=True)


def test_x3p_profile_is_refused():
    with pytest.raises(ConfigError, match="profile"):
        read_topography(DATA / "x3pio_profile_binary.x3p")


# ----------------------------------------------------------------------------- sdf (surfalize)
def test_sdf_sample_has_documented_dimensions():
    # sdfio README: 48 columns x 32 rows, 2 um along x, 3 um along y, rows 10-13 and
    # columns 20-29 missing
    hm = read_topography(DATA / "sdfio_iso1_surface_binary.sdf")
    assert hm.shape == (32, 48)
    assert hm.pitch_x == pytest.approx(2 * UM)
    assert hm.pitch_y == pytest.approx(3 * UM)
    rows, cols = np.nonzero(np.isnan(hm.heights))
    assert (rows.min(), rows.max(), cols.min(), cols.max()) == (10, 13, 20, 29)
    assert 0.3 * UM < np.nanstd(hm.heights) < 1 * UM  # heights in mm, not um or m


# ----------------------------------------------------------------------------- sur (written by
# surfalize)
def test_sur_written_by_surfalize(tmp_path):
    surfalize = pytest.importorskip("surfalize")
    z_um = np.random.default_rng(0).normal(scale=0.3, size=(20, 30))
    path = tmp_path / "written.sur"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        surfalize.Surface(z_um, 0.5, 0.5).save(path)
    hm = read_topography(path)
    assert hm.shape == (20, 30)
    assert hm.pitch_x == pytest.approx(0.5 * UM)
    assert hm.pitch_y == pytest.approx(0.5 * UM)
    # SUR stores integers: quantisation error < 1e-5 of the range
    np.testing.assert_allclose(hm.heights, z_um * UM, atol=1e-5 * np.ptp(z_um) * UM)


def test_plu_garbage_is_a_clear_error(tmp_path):
    path = tmp_path / "broken.plu"
    path.write_bytes(b"not a confocal file" * 10)
    with pytest.raises(ConfigError, match=r"broken\.plu"):
        read_topography(path)


# ----------------------------------------------------------------------------- gwy
def test_gwy_written_by_gwyfile(tmp_path):
    pytest.importorskip("gwyfile")
    from gwyfile.objects import GwyContainer, GwyDataField, GwySIUnit

    z_m = np.random.default_rng(1).normal(scale=2e-7, size=(30, 40))
    container = GwyContainer()
    container["/0/data"] = GwyDataField(
        z_m,
        xreal=40 * 2e-6,
        yreal=30 * 3e-6,
        xoff=5e-6,
        si_unit_xy=GwySIUnit(unitstr="m"),
        si_unit_z=GwySIUnit(unitstr="m"),
    )
    container["/0/data/title"] = "Height"
    container["/1/data"] = GwyDataField(
        np.ones((30, 40)),
        xreal=1.0,
        yreal=1.0,
        si_unit_xy=GwySIUnit(unitstr="m"),
        si_unit_z=GwySIUnit(unitstr="V"),
    )
    container["/1/data/title"] = "Amplitude"
    path = tmp_path / "two_channels.gwy"
    container.tofile(str(path))
    hm = read_topography(path)  # picks the only channel with heights in metres
    assert hm.metadata["channel"] == "Height"
    assert hm.shape == (30, 40)
    assert hm.pitch_x == pytest.approx(2 * UM)
    assert hm.pitch_y == pytest.approx(3 * UM)
    assert hm.origin[0] == pytest.approx(5 * UM)
    np.testing.assert_allclose(hm.heights, z_m * 1e3)
    raw = _surfalize_raw(path)  # independent reader agrees (um)
    np.testing.assert_allclose(hm.heights, raw.data * UM, rtol=1e-12)
    with pytest.raises(ConfigError, match="channel"):
        read_topography(path, channel="Phase")


def test_gwy_sample_without_units():
    # gwyfile's own test file (MIT): one 128 x 128 channel 'Test', no SI units stored
    path = DATA / "gwyfile_test.gwy"
    with pytest.raises(ConfigError, match="xy_unit"):
        read_topography(path)
    hm = read_topography(path, xy_unit="um", z_unit="um")
    assert hm.shape == (128, 128)
    assert hm.pitch_x == pytest.approx(1 * UM)
    assert hm.heights[0, 0] == pytest.approx(
        0.00082494 * UM, rel=1e-4
    )  # value in gwyfile's own test
    assert hm.heights[44, 33] == pytest.approx(0.00085301 * UM, rel=1e-4)


# ----------------------------------------------------------------------------- text grids
def test_text_grid_with_header(tmp_path):
    z = np.arange(12.0).reshape(3, 4)
    path = tmp_path / "grid.txt"
    np.savetxt(path, z, header="pitch_x = 0.5 um\npitch_y = 2 um\nz_unit = nm")
    hm = read_topography(path)
    assert hm.shape == (3, 4)
    assert hm.pitch_x == pytest.approx(0.5 * UM)
    assert hm.pitch_y == pytest.approx(2 * UM)
    np.testing.assert_allclose(hm.heights, z * 1e-6)


def test_csv_grid_with_parameters_and_nan(tmp_path):
    z = np.arange(20.0).reshape(4, 5)
    z[1, 2] = np.nan
    path = tmp_path / "grid.csv"
    np.savetxt(path, z, delimiter=",")
    with pytest.raises(ConfigError, match="pitch"):
        read_topography(path, z_unit="um")
    with pytest.raises(ConfigError, match="z_unit"):
        read_topography(path, pitch="1 um")
    hm = read_topography(path, pitch="1 um", z_unit="um")
    assert hm.pitch_x == hm.pitch_y == pytest.approx(UM)
    assert np.isnan(hm.heights[1, 2])
    assert hm.heights[3, 4] == pytest.approx(19 * UM)


def test_gwyddion_ascii_export_header(tmp_path):
    path = tmp_path / "export.txt"
    path.write_text(
        "# Channel: Height\n# Width: 4.000 µm\n# Height: 2.000 µm\n# Value units: m\n"
        "1e-7 2e-7 3e-7 4e-7\n5e-7 6e-7 7e-7 8e-7\n",
        encoding="utf-8",
    )
    hm = read_topography(path)
    assert hm.pitch_x == pytest.approx(1 * UM)
    assert hm.pitch_y == pytest.approx(1 * UM)
    assert hm.heights[1, 3] == pytest.approx(8e-4)


def test_text_grid_errors(tmp_path):
    ragged = tmp_path / "ragged.txt"
    ragged.write_text("1 2 3\n4 5\n")
    with pytest.raises(ConfigError, match="rows have different"):
        read_topography(ragged, pitch="1 um", z_unit="um")
    empty = tmp_path / "empty.asc"
    empty.write_text("# pitch = 1 um\n")
    with pytest.raises(ConfigError, match=r"empty\.asc.*no data"):
        read_topography(empty, z_unit="um")
    nan_only = tmp_path / "nan.txt"
    nan_only.write_text("nan nan\nnan nan\n")
    with pytest.raises(ConfigError, match="NaN"):
        read_topography(nan_only, pitch="1 um", z_unit="um")


# ----------------------------------------------------------------------------- xyz
def _xyz_lines(x, y, z):
    return "".join(f"{a:.9g} {b:.9g} {c:.9g}\n" for a, b, c in zip(x, y, z, strict=True))


def test_xyz_regular_grid_in_any_order_with_gaps(tmp_path):
    yy, xx = np.meshgrid(10 + 3.0 * np.arange(5), -2 + 2.0 * np.arange(7), indexing="ij")
    zz = 0.1 * xx + yy
    order = np.random.default_rng(0).permutation(xx.size)
    keep = order[2:]  # two grid nodes without a point
    path = tmp_path / "points.xyz"
    path.write_text("X Y Z\n" + _xyz_lines(xx.ravel()[keep], yy.ravel()[keep], zz.ravel()[keep]))
    hm = read_topography(path, xy_unit="um", z_unit="nm")
    assert hm.shape == (5, 7)
    assert hm.pitch_x == pytest.approx(2 * UM)
    assert hm.pitch_y == pytest.approx(3 * UM)
    assert hm.origin == pytest.approx((-2 * UM, 10 * UM))
    assert int(np.isnan(hm.heights).sum()) == 2
    ok = ~np.isnan(hm.heights)
    np.testing.assert_allclose(hm.heights[ok], zz[ok] * 1e-6)


def test_xyz_rejects_non_grid_and_empty_files(tmp_path):
    rng = np.random.default_rng(1)
    scattered = tmp_path / "cloud.xyz"
    scattered.write_text(_xyz_lines(*rng.uniform(size=(3, 200))))
    with pytest.raises(ConfigError, match=r"cloud\.xyz.*regular grid"):
        read_topography(scattered, xy_unit="um", z_unit="um")
    empty = tmp_path / "empty.xyz"
    empty.write_text("")
    with pytest.raises(ConfigError, match=r"empty\.xyz.*no data points"):
        read_topography(empty, xy_unit="um", z_unit="um")
    with pytest.raises(ConfigError, match=r"duplicate|same grid node"):
        grid_from_points([0, 1, 0, 1, 1], [0, 0, 1, 1, 1], [1, 2, 3, 4, 5])
    with pytest.raises(ConfigError, match="at least 50%"):
        grid_from_points(
            [0, 1, 10, 0, 1, 10], [0, 0, 0, 1, 1, 1], np.zeros(6)
        )  # 6 points on an 11 x 2 grid
    with pytest.raises(ConfigError, match="one x value"):
        grid_from_points([1, 1, 1], [0, 1, 2], [0, 0, 0])
    with pytest.raises(ConfigError, match="xy_unit"):
        read_topography(scattered, z_unit="um")


# ----------------------------------------------------------------------------- dispatch
def test_unknown_format_lists_known_formats(tmp_path):
    path = tmp_path / "surface.bmp"
    path.write_bytes(b"BM")
    with pytest.raises(ConfigError, match=r"x3p.*gwy.*plu.*sur.*xyz"):
        read_topography(path)
    with pytest.raises(ConfigError, match="format 'tiff'"):
        read_topography(DATA / "x3pio_surface_binary.x3p", format="tiff")
    with pytest.raises(ConfigError, match="does not exist"):
        read_topography(tmp_path / "missing.x3p")
    assert {"x3p", "plu", "sur", "gwy", "xyz", "txt", "csv"} <= set(FORMATS)
