"""TriangleMesh: construction from height maps, closed bodies, checks and writers."""

from __future__ import annotations

import os

import numpy as np
import pytest

from score4.errors import ConfigError, Score4Error
from score4.surface.heightmap import HeightMap
from score4.surface.triangle_mesh import (
    TriangleMesh,
    closed_body,
    degenerate_faces,
    from_heightmap,
    is_watertight,
    signed_volume,
    write_ply,
    write_stl,
)


def _plane_map(
    nx: int = 7, ny: int = 4, px: float = 0.5, py: float = 0.25, a: float = 0.3, b: float = -0.2
) -> HeightMap:
    x = px * np.arange(nx)
    y = py * np.arange(ny)
    return HeightMap(1.0 + a * x[None, :] + b * y[:, None], px, py, origin=(0.0, 0.0))


def _rough_map(seed: int = 0) -> HeightMap:
    rng = np.random.default_rng(seed)
    return HeightMap(rng.normal(0.0, 0.01, size=(5, 9)), 0.02, 0.03, origin=(-0.1, 0.4))


# --- from_heightmap -----------------------------------------------------------------------


def test_from_heightmap_counts_and_ids():
    hm = _plane_map()
    mesh = from_heightmap(hm)
    assert mesh.n_vertices == 7 * 4
    assert mesh.n_faces == 2 * 6 * 3
    assert mesh.top.all()
    np.testing.assert_array_equal(mesh.facet, np.repeat(np.arange(18), 2))


def test_from_heightmap_plane_normals_and_areas():
    a, b = 0.3, -0.2
    hm = _plane_map(a=a, b=b)
    mesh = from_heightmap(hm)
    expected = np.array([-a, -b, 1.0]) / np.sqrt(1 + a * a + b * b)
    np.testing.assert_allclose(
        mesh.normals, np.broadcast_to(expected, mesh.normals.shape), atol=1e-12
    )
    proj = hm.size_x * hm.size_y
    np.testing.assert_allclose(mesh.projected_areas.sum(), proj, rtol=1e-12)
    np.testing.assert_allclose(mesh.total_area, proj * np.sqrt(1 + a * a + b * b), rtol=1e-12)
    assert mesh.top_area == pytest.approx(mesh.total_area)


def test_from_heightmap_rejects_nan():
    z = np.zeros((3, 3))
    z[1, 1] = np.nan
    with pytest.raises(ConfigError, match="heights: 1 missing"):
        from_heightmap(HeightMap(z, 1.0, 1.0))


@pytest.mark.parametrize(
    ("vertices", "faces", "match"),
    [
        (np.zeros((3, 2)), [[0, 1, 2]], "vertices: need shape"),
        (np.zeros((3, 3)), [[0, 1, 3]], r"faces: indices must lie in \[0, 2\]"),
        (np.zeros((3, 3)), [[0, 1]], "faces: need shape"),
        (
            [[0, 0, 0], [1, 0, 0], [0, np.nan, 0]],
            [[0, 1, 2]],
            "vertices: every coordinate must be finite",
        ),
    ],
)
def test_mesh_validation(vertices, faces, match):
    with pytest.raises(ConfigError, match=match):
        TriangleMesh(vertices, faces)


def test_mesh_arrays_are_read_only_copies():
    v = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]])
    mesh = TriangleMesh(v, [[0, 1, 2]])
    v[0, 0] = 5.0
    assert mesh.vertices[0, 0] == 0.0
    with pytest.raises(ValueError, match="read-only"):
        mesh.vertices[0, 0] = 1.0


# --- closed_body --------------------------------------------------------------------------


def test_closed_body_is_watertight_and_outward():
    hm = _rough_map()
    top = from_heightmap(hm)
    body = closed_body(top, thickness=0.5)
    assert is_watertight(body)
    assert degenerate_faces(body).size == 0
    # Top vertices kept, one bottom copy per boundary vertex, one centre vertex.
    n_boundary = 2 * (9 + 5) - 4
    assert body.n_vertices == top.n_vertices + n_boundary + 1
    assert body.top.sum() == top.n_faces
    np.testing.assert_array_equal(body.faces[: top.n_faces], top.faces)
    np.testing.assert_array_equal(body.facet[top.n_faces :], -1)
    # Bottom faces point down; wall normals are horizontal and point away from the centre.
    n, c = body.normals[~body.top], body.vertices[body.faces[~body.top]].mean(axis=1)
    bottom = np.isclose(c[:, 2], -0.5)
    np.testing.assert_allclose(
        n[bottom], np.broadcast_to([0, 0, -1.0], n[bottom].shape), atol=1e-12
    )
    walls = ~bottom
    np.testing.assert_allclose(n[walls, 2], 0.0, atol=1e-12)
    centre = np.array([hm.x.mean(), hm.y.mean()])
    assert (np.einsum("ij,ij->i", n[walls, :2], c[walls, :2] - centre) > 0).all()


def test_closed_body_volume_of_a_plane_slab():
    hm = _plane_map(a=0.3, b=-0.2)  # heights 1 + 0.3 x - 0.2 y over [0, 3] x [0, 0.75]
    body = closed_body(from_heightmap(hm), thickness=2.0)
    mean_height = 1.0 + 0.3 * 1.5 - 0.2 * 0.375
    expected = hm.size_x * hm.size_y * (mean_height + 2.0)
    assert signed_volume(body) == pytest.approx(expected, rel=1e-12)


@pytest.mark.parametrize("thickness", [0.0, -1.0, float("nan")])
def test_closed_body_rejects_non_positive_thickness(thickness):
    with pytest.raises(ConfigError, match="thickness: must be a positive length"):
        closed_body(from_heightmap(_rough_map()), thickness)


def test_closed_body_rejects_bottom_above_lowest_vertex():
    hm = HeightMap(np.full((3, 3), -1.0), 1.0, 1.0)
    with pytest.raises(ConfigError, match="thickness: the bottom plane"):
        closed_body(from_heightmap(hm), 0.5)


def test_closed_body_rejects_a_top_with_a_hole():
    top = from_heightmap(HeightMap(np.zeros((5, 5)), 1.0, 1.0))
    keep = (top.facet != 5) & (top.facet != 6)  # remove two interior cells
    holed = TriangleMesh(top.vertices, top.faces[keep])
    with pytest.raises(ConfigError, match="top_mesh: its boundary must be one"):
        closed_body(holed, 1.0)


# --- checks -------------------------------------------------------------------------------


def test_is_watertight_detects_open_and_flipped_meshes():
    body = closed_body(from_heightmap(_rough_map()), 0.5)
    assert is_watertight(body)
    assert not is_watertight(from_heightmap(_rough_map()))  # open surface
    flipped = body.faces.copy()
    flipped[0] = flipped[0, ::-1]
    assert not is_watertight(TriangleMesh(body.vertices, flipped))
    dropped = TriangleMesh(body.vertices, body.faces[1:])
    assert not is_watertight(dropped)


def test_signed_volume_sign_follows_orientation():
    body = closed_body(from_heightmap(_rough_map()), 0.5)
    inverted = TriangleMesh(body.vertices, body.faces[:, ::-1])
    assert signed_volume(body) > 0
    assert signed_volume(inverted) == pytest.approx(-signed_volume(body), rel=1e-12)


def test_degenerate_faces_finds_zero_area_and_slivers():
    v = [[0, 0, 0], [1, 0, 0], [0, 1, 0], [2, 0, 0], [1, 1e-12, 0]]
    mesh = TriangleMesh(v, [[0, 1, 2], [0, 1, 3], [0, 3, 4], [0, 0, 2]])
    np.testing.assert_array_equal(degenerate_faces(mesh), [1, 2, 3])
    np.testing.assert_array_equal(degenerate_faces(mesh, rel_tol=1e-15), [1, 3])


# --- writers ------------------------------------------------------------------------------


def _body() -> TriangleMesh:
    return closed_body(from_heightmap(_rough_map()), 0.5)


def test_write_binary_stl_round_trip(tmp_path):
    mesh = _body()
    path = tmp_path / "body.stl"
    write_stl(mesh, path)
    data = path.read_bytes()
    assert len(data) == 84 + 50 * mesh.n_faces
    assert np.frombuffer(data[80:84], "<u4")[0] == mesh.n_faces
    rec = np.frombuffer(data[84:], dtype=[("n", "<f4", (3,)), ("v", "<f4", (3, 3)), ("a", "<u2")])
    np.testing.assert_allclose(rec["v"], mesh.vertices[mesh.faces], rtol=1e-6, atol=1e-7)
    np.testing.assert_allclose(rec["n"], mesh.normals, atol=1e-6)
    assert os.listdir(tmp_path) == ["body.stl"]  # no temporary file left behind


def test_write_ascii_stl(tmp_path):
    mesh = _body()
    path = tmp_path / "body.stl"
    write_stl(mesh, path, binary=False)
    lines = path.read_text().splitlines()
    assert lines[0].startswith("solid")
    assert lines[-1].startswith("endsolid")
    verts = np.array(
        [[float(t) for t in ln.split()[1:]] for ln in lines if ln.strip().startswith("vertex")]
    )
    np.testing.assert_allclose(verts, mesh.vertices[mesh.faces].reshape(-1, 3), rtol=1e-15)


def test_write_ply_round_trip_and_overwrite(tmp_path):
    mesh = _body()
    path = tmp_path / "body.ply"
    path.write_text("old content")
    write_ply(mesh, path)
    data = path.read_bytes()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    header = data[:end].decode()
    assert f"element vertex {mesh.n_vertices}" in header
    assert f"element face {mesh.n_faces}" in header
    nv = mesh.n_vertices
    verts = np.frombuffer(data[end : end + 24 * nv], "<f8").reshape(-1, 3)
    faces = np.frombuffer(
        data[end + 24 * nv :], dtype=[("n", "u1"), ("v", "<i4", (3,)), ("top", "u1")]
    )
    np.testing.assert_array_equal(verts, mesh.vertices)
    np.testing.assert_array_equal(faces["v"], mesh.faces)
    np.testing.assert_array_equal(faces["n"], 3)
    np.testing.assert_array_equal(faces["top"].astype(bool), mesh.top)
    assert os.listdir(tmp_path) == ["body.ply"]


def test_writer_failure_leaves_no_file(tmp_path, monkeypatch):
    mesh = _body()
    path = tmp_path / "body.ply"

    def broken_replace(src, dst):
        raise OSError("disk full")

    monkeypatch.setattr(os, "replace", broken_replace)
    with pytest.raises(Score4Error, match=r"cannot write .*body\.ply.*disk full"):
        write_ply(mesh, path)
    assert os.listdir(tmp_path) == []
