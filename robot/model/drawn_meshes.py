"""The OP3's drawn meshes, simplified once per machine.

The packaged OP3 draws its links with CAD exports of ~930k triangles in all. Nothing collides with them (the robot
collides with its own convex shapes) and no mass comes from them, yet every process that compiles the model spent
~2.5 s on them (the robot, its sensor process, each 3D view and each `humanoid run`), the head camera drew them at
every frame and each 3D view sent and drew them in software WebGL. The same shapes (volume within 1 %, extent
within 0.5 %) take ~38 % of the triangles. They are derived from the packaged files (never copied into the project),
written to the user's cache named by what they were made from, and made again only when that changes.
"""

from __future__ import annotations

import hashlib
import logging
import os
import tempfile
import threading
from pathlib import Path

import fast_simplification
import numpy as np

from robot.user_cache import cache_lock, user_cache_dir

log = logging.getLogger(__name__)

# Of each drawn mesh, the smallest share of its triangles that keeps its shape: volume within 1 % and extent within
# 0.5 % of its size (a fifth of the triangles flattened thin plates of the trunk by 18 mm). Meshes under
# MIN_TRIANGLES, and those no share keeps, are drawn whole.
KEEP_FRACTIONS = (0.2, 0.35, 0.5)
MAX_VOLUME_CHANGE = 0.01
MAX_EXTENT_CHANGE = 0.005
MIN_TRIANGLES = 2_000
_STL_RECORD = np.dtype([("normal", "<f4", 3), ("vertices", "<f4", (3, 3)), ("attribute", "<u2")])


def mesh_cache_dir() -> Path:
    """A per-user cache shared by every process of the app (the placo model's neighbour)."""
    return user_cache_dir("meshes")


def read_binary_stl(path: Path) -> tuple[np.ndarray, np.ndarray] | None:
    """Vertices (n x 3, float32, shared corners merged) and triangles (m x 3, int32) of a binary STL; None for an
    ASCII or damaged one (those are drawn as they are)."""
    data = path.read_bytes()
    if len(data) < 84:
        return None
    count = int(np.frombuffer(data, "<u4", count=1, offset=80)[0])
    if len(data) != 84 + count * _STL_RECORD.itemsize or count == 0:
        return None
    corners = np.frombuffer(data, _STL_RECORD, count=count, offset=84)["vertices"].reshape(-1, 3)
    vertices, index = np.unique(corners, axis=0, return_inverse=True)
    return vertices.astype(np.float32), index.reshape(-1, 3).astype(np.int32)


def write_msh(path: Path, vertices: np.ndarray, triangles: np.ndarray) -> None:
    """MuJoCo's binary mesh format: counts of vertices, normals, texture coordinates and faces, then the arrays
    (MuJoCo computes the normals)."""
    with path.open("wb") as out:
        np.array([len(vertices), 0, 0, len(triangles)], "<i4").tofile(out)
        np.ascontiguousarray(vertices, "<f4").tofile(out)
        np.ascontiguousarray(triangles, "<i4").tofile(out)


def enclosed_volume(vertices: np.ndarray, triangles: np.ndarray) -> float:
    """The volume a closed mesh encloses (the divergence theorem over its triangles)."""
    a, b, c = (vertices[triangles[:, i]].astype(np.float64) for i in range(3))
    return float(np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6.0)


def same_shape(original: tuple[np.ndarray, np.ndarray], candidate: tuple[np.ndarray, np.ndarray]) -> bool:
    """Whether `candidate` keeps `original`'s volume and extent (see MAX_VOLUME_CHANGE, MAX_EXTENT_CHANGE)."""
    (vertices, triangles), (points, faces) = original, candidate
    used = points[np.unique(faces)]
    size = float(np.ptp(vertices, axis=0).max())
    extent_change = np.abs(np.concatenate([used.min(0) - vertices.min(0), used.max(0) - vertices.max(0)])).max()
    volume = enclosed_volume(vertices, triangles)
    if volume == 0.0 or extent_change > MAX_EXTENT_CHANGE * size:
        return False
    return abs(enclosed_volume(points, faces) / volume - 1.0) <= MAX_VOLUME_CHANGE


def simplified(vertices: np.ndarray, triangles: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The mesh at the smallest of KEEP_FRACTIONS of its triangles that keeps its shape (quadric edge collapse),
    or whole."""
    if len(triangles) < MIN_TRIANGLES:
        return vertices, triangles
    for keep in KEEP_FRACTIONS:
        points, faces = fast_simplification.simplify(vertices, triangles, target_reduction=1.0 - keep)
        candidate = (points.astype(np.float32), faces.astype(np.int32))
        if same_shape((vertices, triangles), candidate):
            return candidate
    return vertices, triangles


def _recipe() -> str:
    return (
        f"keep={KEEP_FRACTIONS};volume={MAX_VOLUME_CHANGE};extent={MAX_EXTENT_CHANGE};min={MIN_TRIANGLES};"
        f"fast_simplification={fast_simplification.__version__}"
    )


def drawn_mesh(source: Path, directory: Path | None = None) -> Path:
    """The simplified copy of the drawn mesh `source` (made now when missing), or `source` itself when it cannot be
    read as a binary STL. The copy is named by the source's content and the recipe, and only ever written whole (a
    rename), so processes that make it at the same time, or run different versions, never read half a file."""
    if directory is None:
        try:
            return drawn_mesh(source, mesh_cache_dir())
        except OSError:  # no writable home (a service account): the temporary directory, one per user
            return drawn_mesh(source, Path(tempfile.gettempdir()) / f"humanoid-meshes-{os.getuid()}")
    made_from = source.stat()  # a reinstalled package writes its files anew: size and time name the content
    key = f"{source.resolve()};{made_from.st_size};{made_from.st_mtime_ns};{_recipe()}"
    digest = hashlib.sha256(key.encode()).hexdigest()[:16]
    path = directory / f"{source.stem}_{digest}.msh"
    if path.is_file():
        return path
    directory.mkdir(parents=True, exist_ok=True)
    with cache_lock(directory, "making"):  # processes starting together: one makes it, the others wait and read it
        if path.is_file():
            return path
        return _make(source, path)


def _make(source: Path, path: Path) -> Path:
    mesh = read_binary_stl(source)
    if mesh is None:
        return source
    vertices, triangles = simplified(*mesh)
    directory = path.parent
    partial = directory / f".{path.name}.{os.getpid()}.{threading.get_ident()}"
    write_msh(partial, vertices, triangles)
    os.replace(partial, path)
    log.info("simplified %s: %d -> %d triangles (%s)", source.name, len(mesh[1]), len(triangles), path)
    return path
