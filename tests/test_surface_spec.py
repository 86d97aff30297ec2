"""Surface descriptions (score4.surface.spec) and the surface file (score4.surface.store)."""

from __future__ import annotations

import shutil
from pathlib import Path

import h5py
import numpy as np
import pytest

from score4.errors import ConfigError
from score4.surface.spec import (
    MeasuredSurfaceSpec,
    RandomSurfaceSpec,
    SpikeSurfaceSpec,
    build_surface,
    load_surface_spec,
    parse_surface_spec,
)
from score4.surface.store import load_surface, save_surface

from conftest import ROOT

UM = 1e-3  # mm

SPIKES = {
    "kind": "spikes",
    "nx": 4,
    "ny": 3,
    "width_x": "10 um",
    "width_y": "15 um",
    "height": "8 um",
    "height_sigma": "2 um",
    "seed": 5,
}
RANDOM = {
    "kind": "random",
    "nx": 64,
    "ny": 48,
    "pitch": "1 um",
    "sq": "1 um",
    "corr_length": "5 um",
    "seed": 3,
}
SELF_AFFINE = {
    "kind": "random",
    "model": "self_affine",
    "nx": 64,
    "ny": 64,
    "pitch": "0.5 um",
    "sq": "0.3 um",
    "hurst": 0.7,
    "long_cutoff": "10 um",
    "seed": 4,
}

# A small text grid whose heights are known: z = 10 nm * (i + 2 j) + a bump, pitch 0.5 um.
GRID_NX, GRID_NY = 12, 9


def grid_heights_nm() -> np.ndarray:
    j, i = np.mgrid[0:GRID_NY, 0:GRID_NX]
    return 10.0 * (i + 2 * j) + 50.0 * np.exp(-((i - 6) ** 2 + (j - 4) ** 2) / 4.0)


def write_grid(path: Path) -> Path:
    rows = "\n".join(" ".join(f"{v:.6f}" for v in row) for row in grid_heights_nm())
    path.write_text(f"# pitch = 0.5 um\n# z_unit = nm\n{rows}\n")
    return path


def measured_dict(path: Path, **extra) -> dict:
    return dict(kind="measured", file=str(path), **extra)


# --- validation -----------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("data", "message"),
    [
        (
            {"kind": "spikes", "nx": 2, "ny": 2, "height": "1 um"},
            "give the spike cell size as width",
        ),
        (
            {"kind": "spikes", "nx": 2, "ny": 2, "width_x": "1 um", "height": "1 um"},
            "give the spike cell size as width",
        ),
        (
            {"kind": "spikes", "nx": 0, "ny": 2, "width": "1 um", "height": "1 um"},
            "nx: Input should be greater than 0",
        ),
        (
            {"kind": "spikes", "nx": 2, "ny": 2, "width": "1 um", "height": "-1 um"},
            "height: must be greater than 0, got '-1 um'",
        ),
        (
            {
                "kind": "spikes",
                "nx": 2,
                "ny": 2,
                "width": "1 um",
                "height": "1 um",
                "shape": "cone",
            },
            "shape: Input should be",
        ),
        (
            {
                "kind": "spikes",
                "nx": 2,
                "ny": 2,
                "width": "1 um",
                "height": "1 um",
                "heigth": "2 um",
            },
            "heigth: unknown key",
        ),
        (
            {"kind": "spikes", "nx": 2, "ny": 2, "width": "1 um", "height": 1},
            "height: 1 has no unit",
        ),
        (
            {"kind": "spikes", "nx": 2, "ny": 2, "width": "1 um", "height": "1 parsec"},
            "unknown length unit 'parsec'",
        ),
        ({"kind": "blobs", "nx": 2}, "kind: must be one of spikes, random, measured (got 'blobs')"),
        ({"nx": 2}, "kind: must be one of spikes, random, measured (got None)"),
        (
            {"kind": "random", "nx": 64, "ny": 64, "pitch": "1 um", "sq": "1 um"},
            "model gaussian needs sq and corr_length",
        ),
        (
            {
                "kind": "random",
                "model": "exponential",
                "nx": 64,
                "ny": 64,
                "pitch": "1 um",
                "corr_length": "5 um",
            },
            "model exponential needs sq and corr_length",
        ),
        (
            {
                "kind": "random",
                "nx": 64,
                "ny": 64,
                "pitch": "1 um",
                "sq": "1 um",
                "corr_length": "5 um",
                "hurst": 0.5,
            },
            "hurst: used only with model: self_affine (here model is gaussian)",
        ),
        (
            {
                "kind": "random",
                "model": "self_affine",
                "nx": 64,
                "ny": 64,
                "pitch": "1 um",
                "sq": "1 um",
            },
            "model self_affine needs hurst",
        ),
        (
            {
                "kind": "random",
                "model": "self_affine",
                "nx": 64,
                "ny": 64,
                "pitch": "1 um",
                "hurst": 0.7,
            },
            "needs exactly one of sq and rms_slope",
        ),
        (
            {
                "kind": "random",
                "model": "self_affine",
                "nx": 64,
                "ny": 64,
                "pitch": "1 um",
                "sq": "1 um",
                "hurst": 0.7,
                "rms_slope": 0.1,
            },
            "needs exactly one of sq and rms_slope",
        ),
        (
            {
                "kind": "random",
                "model": "self_affine",
                "nx": 64,
                "ny": 64,
                "pitch": "1 um",
                "sq": "1 um",
                "hurst": 0.7,
                "corr_length": "3 um",
            },
            "corr_length: used only with model: gaussian or exponential (here model is self_affine",
        ),
        (
            {
                "kind": "random",
                "model": "self_affine",
                "nx": 64,
                "ny": 64,
                "pitch": "1 um",
                "sq": "1 um",
                "hurst": 1.5,
            },
            "hurst: Input should be less than 1",
        ),
        (
            {
                "kind": "random",
                "model": "fractal",
                "nx": 64,
                "ny": 64,
                "pitch": "1 um",
                "sq": "1 um",
            },
            "model: Input should be",
        ),
        (
            {
                "kind": "random",
                "nx": 64,
                "ny": 64,
                "pitch": "1 um",
                "sq": "1 um",
                "corr_length": "5",
            },
            "corr_length: '5' has no unit",
        ),
        ({"kind": "measured"}, "file: Field required"),
        ([1, 2], "a surface description must be a mapping, got list"),
    ],
)
def test_invalid_descriptions_give_one_line_naming_the_key(data, message):
    with pytest.raises(ConfigError) as info:
        parse_surface_spec(data, origin="t.yaml")
    text = str(info.value)
    assert message in text
    assert text.startswith("t.yaml: ")
    assert "\n" not in text
    assert "spikes." not in text
    assert "random." not in text


def test_values_are_stored_in_mm_and_widths_filled_in():
    spec = parse_surface_spec(
        {"kind": "spikes", "nx": 3, "ny": 2, "width": "20 um", "height": "0.01 mm"}
    )
    assert isinstance(spec, SpikeSurfaceSpec)
    assert spec.width_x == spec.width_y == pytest.approx(0.02)
    assert spec.height == pytest.approx(0.01)
    assert (spec.shape, spec.height_sigma, spec.n_layers, spec.seed) == ("pyramid", 0.0, 1, 0)
    r = parse_surface_spec(RANDOM)
    assert isinstance(r, RandomSurfaceSpec)
    assert (r.pitch, r.sq, r.corr_length, r.model, r.periodic) == (
        pytest.approx(1e-3),
        pytest.approx(1e-3),
        pytest.approx(5e-3),
        "gaussian",
        True,
    )


# --- building -------------------------------------------------------------------------------


def test_spike_grid_build():
    s = build_surface(parse_surface_spec(SPIKES))
    assert s.heightmap is None
    assert s.spikes.heights.shape == (3, 4)
    assert s.size_x == pytest.approx(40 * UM)
    assert s.size_y == pytest.approx(45 * UM)
    assert s.max_height == pytest.approx(s.spikes.heights.max())
    # 12 heights drawn with mean 8 um, sigma 2 um (seed 5): the sample std of 12 Gaussian values
    # lies within a factor 2 of sigma with probability > 0.99, the mean within 4 sigma/sqrt(12).
    h = s.spikes.heights
    assert 0.5 * 2 * UM < h.std(ddof=1) < 2 * 2 * UM
    assert abs(h.mean() - 8 * UM) < 4 * 2 * UM / np.sqrt(12)
    # Equal pyramids: the tip is the height, the map is centred on the origin with its base at 0.
    flat = build_surface({"kind": "spikes", "nx": 3, "ny": 3, "width": "10 um", "height": "7 um"})
    assert flat.max_height == pytest.approx(7 * UM)
    hm = flat.map
    assert hm.x[0] == pytest.approx(-15 * UM)
    assert hm.x[-1] == pytest.approx(15 * UM)
    assert np.nanmin(hm.heights) == pytest.approx(0.0, abs=1e-15)
    assert np.nanmax(hm.heights) == pytest.approx(7 * UM)


@pytest.mark.parametrize("data", [RANDOM, SELF_AFFINE], ids=["gaussian", "self_affine"])
def test_random_build_sizes_and_periodic_tile(data):
    s = build_surface(parse_surface_spec(data))
    z = s.heightmap.heights
    nx, ny = data["nx"], data["ny"]
    pitch = float(data["pitch"].split()[0]) * UM
    # One period plus the repeated first row/column: a closed tile of nx * pitch.
    assert z.shape == (ny + 1, nx + 1)
    assert s.size_x == pytest.approx(nx * pitch)
    assert s.size_y == pytest.approx(ny * pitch)
    assert np.array_equal(z[0], z[-1])
    assert np.array_equal(z[:, 0], z[:, -1])
    assert s.max_height == pytest.approx(np.ptp(z))
    placed = s.placed_map
    assert placed.origin == pytest.approx((-s.size_x / 2, -s.size_y / 2))
    assert placed.heights.min() == 0.0
    # Non-periodic maps are cropped from a larger field: opposite edges differ.
    open_ = build_surface(parse_surface_spec({**data, "periodic": False}))
    assert open_.heightmap.shape == (ny, nx)
    assert not np.allclose(open_.heightmap.heights[0], open_.heightmap.heights[-1])


def test_random_build_is_seeded():
    a, b = (build_surface(parse_surface_spec(RANDOM)) for _ in range(2))
    c = build_surface(parse_surface_spec({**RANDOM, "seed": 4}))
    assert np.array_equal(a.heightmap.heights, b.heightmap.heights)
    assert not np.allclose(a.heightmap.heights, c.heightmap.heights)


def test_measured_build_levels_and_crops(tmp_path):
    path = write_grid(tmp_path / "grid.txt")
    raw = build_surface(parse_surface_spec(measured_dict(path, level=False)))
    assert raw.heightmap.shape == (GRID_NY, GRID_NX)
    assert raw.size_x == pytest.approx((GRID_NX - 1) * 0.5 * UM)
    assert raw.size_y == pytest.approx((GRID_NY - 1) * 0.5 * UM)
    z_nm = grid_heights_nm()
    assert np.allclose(raw.heightmap.heights, z_nm * 1e-6, rtol=0, atol=1e-12)
    assert raw.max_height == pytest.approx(np.ptp(z_nm) * 1e-6)
    # Levelling removes the tilt 10 nm per sample in x and 20 nm in y: only the bump is left.
    levelled = build_surface(parse_surface_spec(measured_dict(path)))
    assert levelled.max_height < 0.5 * raw.max_height
    cropped = build_surface(
        parse_surface_spec(measured_dict(path, crop_x=["1 um", "4 um"], level=False))
    )
    assert cropped.heightmap.shape == (GRID_NY, 7)
    assert cropped.size_x == pytest.approx(3 * UM)


def test_measured_file_with_missing_points_is_refused_unless_filled(tmp_path):
    text = write_grid(tmp_path / "grid.txt").read_text().splitlines()
    row = text[4].split()
    row[3] = "nan"
    text[4] = " ".join(row)
    path = tmp_path / "gap.txt"
    path.write_text("\n".join(text) + "\n")
    with pytest.raises(ConfigError, match=r"1 missing \(NaN\) points; set fill_missing: true"):
        build_surface(parse_surface_spec(measured_dict(path)))
    filled = build_surface(parse_surface_spec(measured_dict(path, fill_missing=True, level=False)))
    assert np.isfinite(filled.heightmap.heights).all()


# --- YAML files -----------------------------------------------------------------------------


def test_load_surface_spec_makes_measured_path_relative_to_the_yaml(tmp_path, monkeypatch):
    folder = tmp_path / "desc"
    folder.mkdir()
    write_grid(folder / "grid.txt")
    (folder / "m.yaml").write_text("kind: measured\nfile: grid.txt\nlevel: false\n")
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)  # the path must not depend on the working folder
    spec = load_surface_spec(folder / "m.yaml")
    assert isinstance(spec, MeasuredSurfaceSpec)
    assert spec.file.resolve() == (folder / "grid.txt").resolve()
    assert build_surface(spec).heightmap.shape == (GRID_NY, GRID_NX)
    # An absolute path is kept as it is.
    (folder / "abs.yaml").write_text(f"kind: measured\nfile: {folder / 'grid.txt'}\n")
    assert load_surface_spec(folder / "abs.yaml").file == folder / "grid.txt"


def test_load_surface_spec_errors(tmp_path):
    with pytest.raises(ConfigError, match="does not exist"):
        load_surface_spec(tmp_path / "none.yaml")
    bad = tmp_path / "bad.yaml"
    bad.write_text("kind: spikes\nnx: [1, 2\n")
    with pytest.raises(ConfigError, match="not valid YAML"):
        load_surface_spec(bad)
    typo = tmp_path / "typo.yaml"
    typo.write_text("kind: spikes\nnx: 2\nny: 2\nwidth: 1 um\nheight: 1 um\nsead: 3\n")
    with pytest.raises(ConfigError, match=r"typo.yaml: sead: unknown key"):
        load_surface_spec(typo)


@pytest.mark.parametrize("name", ["pyramids", "random_gaussian", "self_affine", "measured"])
def test_shipped_examples_are_valid(name):
    spec = load_surface_spec(ROOT / "examples" / "surfaces" / f"{name}.yaml")
    assert spec.kind == {"pyramids": "spikes", "measured": "measured"}.get(name, "random")
    if name == "pyramids":  # the paper's surface
        assert (spec.nx, spec.ny, spec.width_x, spec.height) == (
            50,
            50,
            pytest.approx(0.01),
            pytest.approx(0.01),
        )
    if name == "measured":
        assert build_surface(spec).heightmap.shape == (
            60,
            77,
        )  # 80 x 60 points, cropped to 1..39 um


# --- the surface file -----------------------------------------------------------------------


def test_store_round_trip_spikes(tmp_path):
    s = build_surface(parse_surface_spec(SPIKES))
    path = save_surface(s, tmp_path / "s.s4s.h5")
    back = load_surface(path)
    assert back.spec == s.spec
    assert back.heightmap is None
    assert np.array_equal(back.spikes.heights, s.spikes.heights)
    assert np.array_equal(back.top_mesh.vertices, s.top_mesh.vertices)
    with h5py.File(path) as f:
        assert f.attrs["format"] == "score4-surface"
        assert f.attrs["kind"] == "spikes"
        assert f["spikes/heights"].attrs["units"] == "mm"
    assert [p.name for p in tmp_path.iterdir()] == ["s.s4s.h5"]  # no temporary file left


@pytest.mark.parametrize(
    "data",
    [RANDOM, SELF_AFFINE, {**RANDOM, "periodic": False}],
    ids=["gaussian", "self_affine", "open"],
)
def test_store_round_trip_random_bit_for_bit(tmp_path, data):
    s = build_surface(parse_surface_spec(data))
    back = load_surface(save_surface(s, tmp_path / "r.s4s.h5"))
    assert back.spec == s.spec
    assert back.spikes is None
    assert np.array_equal(back.heightmap.heights, s.heightmap.heights)
    assert (back.heightmap.pitch_x, back.heightmap.pitch_y) == (
        s.heightmap.pitch_x,
        s.heightmap.pitch_y,
    )
    assert back.heightmap.origin == s.heightmap.origin
    assert np.array_equal(back.placed_map.heights, s.placed_map.heights)


def test_store_round_trip_measured_no_longer_needs_the_file(tmp_path):
    path = write_grid(tmp_path / "grid.txt")
    s = build_surface(
        parse_surface_spec(measured_dict(path, crop_y=["0.5 um", "3 um"], resample_pitch="0.25 um"))
    )
    out = save_surface(s, tmp_path / "m.s4s.h5")
    path.unlink()
    back = load_surface(out)
    assert back.spec == s.spec
    assert np.array_equal(back.heightmap.heights, s.heightmap.heights)
    assert back.heightmap.pitch_x == s.heightmap.pitch_x == pytest.approx(0.25 * UM)
    assert back.metadata.get("format") == "txt"  # the reader's provenance is kept


def test_save_replaces_an_existing_file(tmp_path):
    path = tmp_path / "x.s4s.h5"
    save_surface(build_surface(parse_surface_spec(RANDOM)), path)
    save_surface(build_surface(parse_surface_spec(SPIKES)), path)
    assert load_surface(path).spec.kind == "spikes"


def _junk(path: Path, _source: Path) -> None:
    path.write_bytes(b"not an HDF5 file " * 64)


def _foreign(path: Path, _source: Path) -> None:
    with h5py.File(path, "w") as f:
        f["data"] = np.arange(5)


def _truncated(path: Path, source: Path) -> None:
    data = source.read_bytes()
    path.write_bytes(data[: len(data) // 2])


def _future(path: Path, source: Path) -> None:
    shutil.copy(source, path)
    with h5py.File(path, "a") as f:
        f.attrs["format_version"] = 99


def _tampered(path: Path, source: Path) -> None:
    shutil.copy(source, path)
    with h5py.File(path, "a") as f:
        f["spikes/heights"][0, 0] += 1e-3


@pytest.mark.parametrize(
    ("damage", "message"),
    [
        (_junk, "is not an HDF5 file"),
        (_foreign, "is not a score4 surface file"),
        (_truncated, "is not an HDF5 file"),
        (_future, "has format version 99; this score4 reads up to 1"),
        (_tampered, "spike heights rebuilt from the stored description differ"),
    ],
    ids=["junk", "foreign", "truncated", "future", "tampered"],
)
def test_damaged_or_foreign_files_give_a_clear_error(tmp_path, damage, message):
    source = save_surface(build_surface(parse_surface_spec(SPIKES)), tmp_path / "good.s4s.h5")
    bad = tmp_path / "bad.s4s.h5"
    damage(bad, source)
    with pytest.raises(ConfigError, match=message) as info:
        load_surface(bad)
    assert str(bad) in str(info.value)
    assert "\n" not in str(info.value)


def test_missing_surface_file(tmp_path):
    with pytest.raises(ConfigError, match="does not exist"):
        load_surface(tmp_path / "none.s4s.h5")


def test_file_with_format_tag_but_no_data_gives_a_clear_error(tmp_path):
    path = tmp_path / "half.s4s.h5"
    with h5py.File(path, "w") as f:
        f.attrs["format"] = "score4-surface"
    with pytest.raises(ConfigError, match=r"half\.s4s\.h5 is damaged or incomplete"):
        load_surface(path)
