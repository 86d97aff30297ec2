"""legend-lh5io (``import lh5``, the LEGEND reader) reads score4's vertex and results files.

These are files of score4 read by a library nobody here wrote: a failure means a LEGEND user
cannot open our output. lh5 0.3.0 needs a ``datatype`` attribute on every group it reads
(``table{...}``, ``struct{...}``) and column; it returns LH5 string arrays as bytes (also for the
files it writes itself), so ``particle`` is compared after decoding.
"""

from __future__ import annotations

import numpy as np
import pytest

from score4.cli.main import main
from score4.runner.output import merge_chunks, write_chunk
from score4.source.primaries import Primaries
from score4.source.vertex_file import read_vertex_file

lh5 = pytest.importorskip("lh5")

CONFIG = """\
surfaces:
  pyramids: {kind: spikes, nx: 20, ny: 20, width: 10 um, height: 10 um}
targets:
  - name: crystal
    material: G4_Si
    size: [0.4 mm, 0.4 mm, 0.1 mm]
    rough: [{face: "+z", surface: pyramids}]
source:
  decay: Po210
  surface: {volume: crystal, face: "+z"}
  depth: {profile: uniform, max: 50 nm}
run: {events: 30, seed: 4}
"""


@pytest.fixture
def vertex_file(tmp_path):
    cfg = tmp_path / "cfg.yaml"
    cfg.write_text(CONFIG)
    out = tmp_path / "v.h5"
    assert main(["vertices", str(cfg), "--out", str(out)]) == 0
    return out


def test_lh5_reads_vertices_table_with_units_and_particles(vertex_file):
    ours = read_vertex_file(vertex_file)
    table = lh5.read("vertices", vertex_file)
    assert list(table.keys()) == [
        "event",
        "particle",
        "energy",
        "xloc",
        "yloc",
        "zloc",
        "dirx",
        "diry",
        "dirz",
        *sorted(ours.extra),
    ]
    assert table["energy"].attrs["units"] == "MeV"
    assert table["zloc"].attrs["units"] == "mm"
    assert table["depth"].attrs["units"] == "mm"
    particles = [p.decode() for p in table["particle"].nda]
    assert particles == list(ours.particle)
    assert set(particles) == {"alpha", "Pb206"}
    assert np.array_equal(table["xloc"].nda, ours.position[:, 0])
    frame = table.view_as("pd")
    assert len(frame) == 60  # Po210: alpha + recoil per event


def test_lh5_reads_vtx_pos_as_remage_expects(vertex_file):
    ours = read_vertex_file(vertex_file)
    vtx = lh5.read("vtx", vertex_file)
    pos = vtx["pos"]
    assert list(pos.keys()) == ["xloc", "yloc", "zloc"]
    first = ours.event_offsets()[:-1]
    for k, name in enumerate(("xloc", "yloc", "zloc")):
        assert pos[name].attrs["units"] == "mm"
        assert pos[name].nda.dtype == np.float64  # remage does not convert float types
        assert np.array_equal(pos[name].nda, ours.position[first, k])
    assert np.array_equal(lh5.read("vtx/pos", vertex_file)["zloc"].nda, pos["zloc"].nda)


def _primaries(n: int, extra_order: tuple[str, ...]) -> Primaries:
    rng = np.random.default_rng(1)
    extras = {"depth": rng.random(n), "facet": np.arange(n), "patch": -np.ones(n, int)}
    return Primaries(
        event=np.arange(n),
        particle=np.array(["alpha"] * n),
        energy=np.full(n, 5.3),
        position=rng.random((n, 3)),
        direction=np.tile([0.0, 0.0, 1.0], (n, 1)),
        extra={k: extras[k] for k in extra_order},
    )


def test_lh5_reads_results_events_and_primaries_in_one_column_order(tmp_path):
    """Chunks whose sources built their extras in different orders give one column order."""
    chunks = []
    for i, order in enumerate((("patch", "depth", "facet"), ("depth", "facet", "patch"))):
        path = tmp_path / f"c{i}.h5"
        scores = {"edep": np.full((4, 2), 1.5 + i), "track_length": np.ones((4, 2))}
        write_chunk(path, 4 * i, ["target", "world"], scores, _primaries(4, order))
        chunks.append(path)
        assert list(lh5.read("primaries", path).keys())[-3:] == ["depth", "facet", "patch"]
    out = tmp_path / "r.h5"
    merge_chunks(chunks, out, {"seed": 1})
    events = lh5.read("events", out)
    assert list(events.keys()) == ["event_id", "primary_energy", "edep", "track_length"]
    assert list(events["edep"].keys()) == ["target", "world"]
    assert events["edep"]["target"].attrs["units"] == "MeV"
    assert np.array_equal(events["edep"]["world"].nda, [1.5] * 4 + [2.5] * 4)
    assert np.array_equal(events["event_id"].nda, np.arange(8))
    prim = lh5.read("primaries", out)
    assert len(prim) == 8
    assert prim["particle"].nda[0].decode() == "alpha"


def test_particle_column_is_stored_as_lh5_writes_strings(vertex_file, tmp_path):
    """lh5 0.3.0 has no string layout that it reads back as str: it writes strings as
    fixed-width bytes with ``array<1>{string}`` (numpy str arrays it cannot write at all) and
    reads fixed-width and variable-length strings alike as bytes. Our column is stored as
    lh5 stores a string Array, so lh5 users meet it as they meet LEGEND's own files."""
    import h5py
    import lgdo

    theirs = tmp_path / "theirs.lh5"
    lh5.write(lgdo.Array(np.array([b"alpha", b"Pb206"])), "particle", str(theirs))
    with h5py.File(vertex_file) as ours, h5py.File(theirs) as legend:
        mine, their = ours["vertices/particle"], legend["particle"]
        assert mine.dtype.kind == their.dtype.kind == "S"
        assert mine.attrs["datatype"] == their.attrs["datatype"] == "array<1>{string}"
    assert isinstance(lh5.read("particle", theirs).nda[0], bytes)
    assert isinstance(lh5.read("vertices/particle", vertex_file).nda[0], bytes)


def test_vtx_group_follows_remage_vertex_reader(vertex_file):
    """What remage's LH5 input conversion (RMGConvertLH5::ConvertTableToNTuple) and
    RMGVertexFromFile require: every child of /vtx a group whose ``datatype`` is table{...},
    only 1-D datasets of one length below it; ``pos`` with float64 (HDF5 "double")
    xloc/yloc/zloc carrying one string ``units`` of nm, um, mm, cm or m."""
    import h5py

    with h5py.File(vertex_file) as f:
        vtx = f["vtx"]
        assert sorted(vtx) == ["kin", "pos"]
        assert vtx.attrs["datatype"] == "struct{pos,kin}"
        pos = vtx["pos"]
        assert isinstance(pos, h5py.Group)
        assert pos.attrs["datatype"] == "table{xloc,yloc,zloc}"
        assert sorted(pos) == ["xloc", "yloc", "zloc"]
        lengths = {pos[c].shape for c in pos}
        assert lengths == {(f.attrs["n_events"],)}
        units = set()
        for column in pos.values():
            assert column.dtype == np.float64
            kind = column.attrs.get_id("units").get_type()
            assert kind.get_class() == h5py.h5t.STRING
            units.add(column.attrs["units"])
        assert units == {"mm"}


def test_vtx_kin_follows_remage_generator_reader(tmp_path):
    """remage's ``FromFile`` generator (RMGGeneratorFromFile, read at legend-exp/remage) reads
    ``vtx/kin``: integer ``g4_pid`` (PDG code) and ``n_part``, double ``ekin`` (units eV, keV,
    MeV or GeV), ``px/py/pz`` and ``time`` (units ns, ms or s); an event is a row with
    ``n_part`` > 0 followed by ``n_part - 1`` rows with ``n_part`` = 0. Read as remage walks it,
    the file gives each event's particles, energies, directions and decay times; legend-lh5io
    reads it as a table."""
    import h5py

    from score4.source.vertex_file import pdg_codes

    cfg = tmp_path / "chain.yaml"
    cfg.write_text(
        CONFIG.replace("decay: Po210", "decay: {chain: Rn222, until: Pb210}").replace(
            "events: 30", "events: 200"
        )
    )
    out = tmp_path / "chain.h5"
    assert main(["vertices", str(cfg), "--out", str(out)]) == 0
    ours = read_vertex_file(out)
    with h5py.File(out) as f:
        kin = f["vtx/kin"]
        assert kin.attrs["datatype"] == "table{ekin,g4_pid,px,py,pz,time,n_part}"
        for name in ("g4_pid", "n_part"):
            assert kin[name].id.get_type().get_class() == h5py.h5t.INTEGER
            assert kin[name].dtype == np.int32
        for name in ("ekin", "px", "py", "pz", "time"):
            assert kin[name].dtype == np.float64
        assert kin["ekin"].attrs["units"] in ("eV", "keV", "MeV", "GeV")
        assert kin["time"].attrs["units"] in ("ns", "ms", "s")
        rows = {name: kin[name][()] for name in kin}
    # remage's loop: the first row of an event says how many rows it has
    events, row = [], 0
    while row < len(rows["n_part"]):
        n = int(rows["n_part"][row])
        assert n > 0
        assert not rows["n_part"][row + 1 : row + n].any()
        events.append(range(row, row + n))
        row += n
    assert len(events) == 200
    offsets = ours.event_offsets()
    for k, rng in enumerate(events):
        assert (rng.start, rng.stop) == (offsets[k], offsets[k + 1])
    assert np.array_equal(rows["g4_pid"], pdg_codes(ours.particle))
    assert np.array_equal(rows["ekin"], ours.energy)
    assert np.array_equal(np.column_stack([rows["px"], rows["py"], rows["pz"]]), ours.direction)
    assert np.allclose(rows["time"], ours.extra["time"] * 1e9)
    assert rows["time"].max() > 0  # Po-214 within the window of its Bi-214 decay
    codes = dict(zip(ours.particle, rows["g4_pid"], strict=True))
    assert codes["alpha"] == 1000020040
    assert codes["Pb210"] == 1000822100
    assert codes["e-"] == 11
    assert codes["gamma"] == 22
    table = lh5.read("vtx/kin", out)
    assert list(table.keys()) == ["ekin", "g4_pid", "px", "py", "pz", "time", "n_part"]
    assert np.array_equal(table["g4_pid"].nda, rows["g4_pid"])
    assert pdg_codes(np.array(["alpha", "geantino"])) is None  # no kin table for geantinos
