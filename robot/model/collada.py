"""A triangle mesh as a COLLADA document, to embed in a URDF as a `data:` URI.

Why COLLADA: it is the one mesh format whose files say which axis is up (`<up_axis>Z_UP</up_axis>`), and
Foxglove's and Lichtblick's 3D panels honour it; they turn STL and OBJ meshes by a per-panel setting (Y-up by
default), so an STL robot would lie on its side in a panel left at its defaults. RViz reads it the same way.
"""

from __future__ import annotations

import base64
import io
from datetime import UTC, datetime

import collada
import numpy as np
from collada import asset, geometry, scene, source

MEDIA_TYPE = "model/vnd.collada+xml"
# A fixed creation time: the same mesh always gives the same document (and the same URDF).
_EPOCH = datetime(2000, 1, 1, tzinfo=UTC)


def face_normals(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """One unit normal per triangle (counter-clockwise winding faces out), for flat shading of convex shapes."""
    a, b, c = (vertices[faces[:, k]] for k in range(3))
    normals = np.cross(b - a, c - a)
    lengths = np.linalg.norm(normals, axis=1, keepdims=True)
    return normals / np.where(lengths > 0, lengths, 1.0)


def collada_document(vertices: np.ndarray, faces: np.ndarray, name: str = "mesh") -> bytes:
    """`vertices` (n, 3) in metres, `faces` (m, 3) vertex indices: a Z-up COLLADA 1.4 document with flat normals."""
    vertices = np.asarray(vertices, dtype=float).reshape(-1, 3)
    faces = np.asarray(faces, dtype=int).reshape(-1, 3)
    doc = collada.Collada()
    doc.assetInfo.upaxis = asset.UP_AXIS.Z_UP
    doc.assetInfo.unitmeter = 1.0
    doc.assetInfo.unitname = "meter"
    doc.assetInfo.created = doc.assetInfo.modified = _EPOCH
    # to 10 micrometres and a thousandth of a normal: a third of the text, nothing a viewer can see
    positions = source.FloatSource(f"{name}-positions", np.round(vertices, 5).ravel(), ("X", "Y", "Z"))
    normals = source.FloatSource(f"{name}-normals", np.round(face_normals(vertices, faces), 3).ravel(), ("X", "Y", "Z"))
    geom = geometry.Geometry(doc, f"{name}-geometry", name, [positions, normals])
    inputs = source.InputList()
    inputs.addInput(0, "VERTEX", f"#{name}-positions")
    inputs.addInput(1, "NORMAL", f"#{name}-normals")
    # each corner: (vertex index, its face's normal index)
    face_of_corner = np.repeat(np.arange(len(faces))[:, None], 3, axis=1)
    indices = np.stack([faces, face_of_corner], axis=-1).ravel()
    geom.primitives.append(geom.createTriangleSet(indices, inputs, "material"))
    doc.geometries.append(geom)
    root = scene.Scene(f"{name}-scene", [scene.Node(name, children=[scene.GeometryNode(geom, [])])])
    doc.scenes.append(root)
    doc.scene = root
    out = io.BytesIO()
    doc.write(out)
    return out.getvalue()


def data_uri(data: bytes, media_type: str = MEDIA_TYPE) -> str:
    """`data:` URI carrying `data` (base64): a mesh that travels inside the file that names it."""
    return f"data:{media_type};base64,{base64.b64encode(data).decode('ascii')}"


def read_data_uri(uri: str) -> tuple[str, bytes]:
    """(media type, bytes) of a base64 `data:` URI; ValueError for anything else."""
    head, sep, payload = uri.partition(",")
    if not (uri.startswith("data:") and sep and head.endswith(";base64")):
        raise ValueError("not a base64 data: URI")
    return head[len("data:") : -len(";base64")], base64.b64decode(payload)
