"""The OP3's drawn meshes: simplified once, the same shapes, and nothing the robot collides with changed."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest

from robot.model import humanoid_v1, op3
from robot.model.drawn_meshes import drawn_mesh, read_binary_stl


def _mesh_geoms(spec: mujoco.MjSpec) -> tuple[set[str], set[str]]:
    drawn, colliding = set(), set()
    for geom in spec.geoms:
        if geom.type == mujoco.mjtGeom.mjGEOM_MESH:
            (colliding if geom.contype or geom.conaffinity else drawn).add(geom.meshname)
    return drawn, colliding


def _read_msh(path: Path) -> tuple[np.ndarray, np.ndarray]:
    data = path.read_bytes()
    nvert, nnormal, ntex, nface = np.frombuffer(data, "<i4", count=4)
    vertices = np.frombuffer(data, "<f4", count=3 * nvert, offset=16).reshape(-1, 3)
    offset = 16 + 4 * (3 * nvert + 3 * nnormal + 2 * ntex)
    return vertices, np.frombuffer(data, "<i4", count=3 * nface, offset=offset).reshape(-1, 3)


def _volume(vertices: np.ndarray, faces: np.ndarray) -> float:
    a, b, c = (vertices[faces[:, i]].astype(np.float64) for i in range(3))
    return float(np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6.0)


def test_the_drawn_meshes_keep_their_shape_with_fewer_triangles_and_collisions_are_untouched() -> None:
    spec = humanoid_v1.build_robot_spec()
    drawn, colliding = _mesh_geoms(spec)
    packaged = op3.op3_asset_dir() / "assets"
    before = after = 0
    for mesh in spec.meshes:
        path = Path(mesh.file)
        if mesh.name in colliding:  # the robot collides with the packaged shapes, as before
            assert not path.is_absolute() and (packaged / path).is_file(), mesh.name
            continue
        if mesh.name not in drawn:  # declared by the package, used by no geom
            continue
        assert path.suffix == ".msh", mesh.name
        original, original_faces = read_binary_stl(packaged / f"{mesh.name}.stl")
        vertices, faces = _read_msh(path)
        before, after = before + len(original_faces), after + len(faces)
        assert faces.min() >= 0 and faces.max() < len(vertices)
        # the same shape: its extent within 0.5 % of the part's size, the volume it encloses within 1 %
        size = np.ptp(original, axis=0).max()
        drawn_corners = vertices[np.unique(faces)]
        assert np.allclose(drawn_corners.min(axis=0), original.min(axis=0), atol=0.005 * size), mesh.name
        assert np.allclose(drawn_corners.max(axis=0), original.max(axis=0), atol=0.005 * size), mesh.name
        assert _volume(vertices, faces) == pytest.approx(_volume(original, original_faces), rel=0.01), mesh.name
    assert before > 900_000 and after < 0.5 * before

    model = spec.compile()  # compiles, with the masses the packaged robot states
    packaged_model = mujoco.MjSpec.from_file(str(op3.op3_asset_dir() / "op3.xml")).compile()
    for body in range(packaged_model.nbody):
        name = packaged_model.body(body).name
        assert model.body(name).mass[0] == packaged_model.body(body).mass[0], name


def test_a_simplified_mesh_is_made_once_and_a_file_it_cannot_read_is_drawn_as_it_is(tmp_path: Path) -> None:
    source = op3.op3_asset_dir() / "assets" / "la2.stl"
    made = drawn_mesh(source, tmp_path)
    assert made.parent == tmp_path and made.suffix == ".msh"
    written = made.stat().st_mtime_ns
    assert drawn_mesh(source, tmp_path) == made and made.stat().st_mtime_ns == written  # kept, not made again
    assert [p.name for p in tmp_path.iterdir() if p.suffix == ".msh"] == [made.name]
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(f".{made.name}")]  # nothing half-written left

    ascii_stl = tmp_path / "part.stl"
    ascii_stl.write_text("solid part\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\n")
    assert drawn_mesh(ascii_stl, tmp_path / "other") == ascii_stl
