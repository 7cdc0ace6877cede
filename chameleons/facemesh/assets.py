"""Read the vendored ``@mediapipe/face_mesh`` package: packed models and face geometry.

The npm package (Apache-2.0) ships its four model files concatenated in
``face_mesh_solution_packed_assets.data``; ``face_mesh_solution_packed_assets_loader.js``
lists each file's byte range (``loadPackage({"files": [{"filename", "start", "end"}]})``).
:func:`read_packed` returns one of them by its base name, so Python runs the very models
the browser runs. The face-geometry metadata is the protobuf message
``mediapipe.face_geometry.GeometryPipelineMetadata`` (mediapipe/modules/face_geometry/
protos/geometry_pipeline_metadata.proto and mesh_3d.proto): field 1 the canonical
``Mesh3d`` (vertex_type VERTEX_PT: x, y, z in cm then u, v per vertex; triangle indices),
field 2 the weighted landmarks of the Procrustes basis. It is decoded here with a small
reader of the protobuf wire format instead of a protobuf dependency.
"""

from __future__ import annotations

import json
import re
import struct
from dataclasses import dataclass
from functools import cache
from pathlib import Path
from typing import Final

VERSION: Final = "0.4.1633559619"
VENDOR_DIR: Final = (
    Path(__file__).resolve().parents[1] / "frontend" / "static" / "vendor" / "mediapipe-face-mesh"
)
PACKED_DATA: Final = "face_mesh_solution_packed_assets.data"
PACKED_LOADER: Final = "face_mesh_solution_packed_assets_loader.js"
GEOMETRY_FILE: Final = "geometry_pipeline_metadata_landmarks.binarypb"
MESH_JSON: Final = "canonical_face_mesh.json"
_FILE_ENTRY = re.compile(r'"filename":\s*"([^"]+)",\s*"start":\s*(\d+),\s*"end":\s*(\d+)')


@cache
def packed_files(vendor_dir: Path = VENDOR_DIR) -> dict[str, tuple[int, int]]:
    """Base name -> (start, end) byte range in the packed data file."""
    loader = (vendor_dir / PACKED_LOADER).read_text("utf-8")
    files = {Path(name).name: (int(a), int(b)) for name, a, b in _FILE_ENTRY.findall(loader)}
    if not files:
        raise ValueError(f"{PACKED_LOADER}: no packed files listed")
    return files


def read_packed(name: str, vendor_dir: Path = VENDOR_DIR) -> bytes:
    """One packed model file (e.g. ``face_landmark.tflite``) as bytes."""
    start, end = packed_files(vendor_dir)[name]
    with (vendor_dir / PACKED_DATA).open("rb") as data:
        data.seek(start)
        blob = data.read(end - start)
    if len(blob) != end - start:
        raise ValueError(f"{PACKED_DATA} is truncated: {name} needs bytes {start}-{end}")
    return blob


@dataclass(frozen=True)
class CanonicalMesh:
    """MediaPipe's canonical face: 468 vertices (cm, the face looking along +z), UVs,
    triangles (indices into the vertices, three per face) and the Procrustes basis
    (landmark id -> weight; the landmarks the pose fit uses, the rest weigh 0)."""

    positions: tuple[tuple[float, float, float], ...]
    uvs: tuple[tuple[float, float], ...]
    triangles: tuple[tuple[int, int, int], ...]
    procrustes: dict[int, float]


def _varint(buf: bytes, pos: int) -> tuple[int, int]:
    value = shift = 0
    while True:
        byte = buf[pos]
        pos += 1
        value |= (byte & 0x7F) << shift
        if byte < 0x80:
            return value, pos
        shift += 7


def _fields(buf: bytes) -> list[tuple[int, int, int | bytes]]:
    """(field number, wire type, value) of each field; length-delimited values as bytes,
    32-bit values as their raw 4 bytes."""
    out: list[tuple[int, int, int | bytes]] = []
    pos = 0
    while pos < len(buf):
        key, pos = _varint(buf, pos)
        number, wire = key >> 3, key & 7
        value: int | bytes
        if wire == 0:
            value, pos = _varint(buf, pos)
        elif wire == 1:
            value, pos = buf[pos : pos + 8], pos + 8
        elif wire == 2:
            size, pos = _varint(buf, pos)
            value, pos = buf[pos : pos + size], pos + size
        elif wire == 5:
            value, pos = buf[pos : pos + 4], pos + 4
        else:
            raise ValueError(f"unsupported protobuf wire type {wire}")
        out.append((number, wire, value))
    return out


def _floats(fields: list[tuple[int, int, int | bytes]], number: int) -> list[float]:
    """A repeated float field, packed (wire type 2) or not (wire type 5)."""
    values: list[float] = []
    for num, wire, value in fields:
        if num == number and isinstance(value, bytes):
            count = len(value) // 4
            values.extend(struct.unpack(f"<{count}f", value) if wire == 2 else
                          struct.unpack("<f", value))  # fmt: skip
    return values


def _uints(fields: list[tuple[int, int, int | bytes]], number: int) -> list[int]:
    values: list[int] = []
    for num, _wire, value in fields:
        if num != number:
            continue
        if isinstance(value, int):
            values.append(value)
        else:  # packed varints
            pos = 0
            while pos < len(value):
                item, pos = _varint(value, pos)
                values.append(item)
    return values


def decode_geometry(blob: bytes) -> CanonicalMesh:
    """Decode ``GeometryPipelineMetadata`` (see the module's docstring)."""
    top = _fields(blob)
    mesh_bytes = next(v for n, _w, v in top if n == 1 and isinstance(v, bytes))
    mesh = _fields(mesh_bytes)
    vertex_type = next((v for n, _w, v in mesh if n == 1 and isinstance(v, int)), 0)
    if vertex_type != 0:
        raise ValueError(f"canonical mesh: vertex type {vertex_type}, expected VERTEX_PT (0)")
    flat = _floats(mesh, 3)
    indices = _uints(mesh, 4)
    if len(flat) % 5 or len(indices) % 3:
        raise ValueError("canonical mesh: vertex or index buffer of the wrong length")
    vertices = [flat[i : i + 5] for i in range(0, len(flat), 5)]
    basis: dict[int, float] = {}
    for number, _wire, value in top:
        if number == 2 and isinstance(value, bytes):
            ref = _fields(value)
            landmark = next((int(v) for n, _w, v in ref if n == 1 and isinstance(v, int)), 0)
            weight = next(iter(_floats(ref, 2)), 0.0)
            basis[landmark] = weight
    return CanonicalMesh(
        positions=tuple((v[0], v[1], v[2]) for v in vertices),
        uvs=tuple((v[3], v[4]) for v in vertices),
        triangles=tuple(
            (indices[i], indices[i + 1], indices[i + 2]) for i in range(0, len(indices), 3)
        ),
        procrustes=basis,
    )


def canonical_mesh_json(vendor_dir: Path = VENDOR_DIR) -> str:
    """The canonical mesh as the JSON file both the tracker and the 3D head read."""
    mesh = decode_geometry(read_packed(GEOMETRY_FILE, vendor_dir))
    return json.dumps({
        "source": f"@mediapipe/face_mesh {VERSION}, {GEOMETRY_FILE} (Apache-2.0)",
        "units": "cm",
        "positions": [[round(c, 6) for c in p] for p in mesh.positions],
        "uvs": [[round(c, 6) for c in uv] for uv in mesh.uvs],
        "triangles": [list(t) for t in mesh.triangles],
        "procrustes": {str(k): round(w, 6) for k, w in sorted(mesh.procrustes.items())},
    }, separators=(",", ":"))  # fmt: skip


@cache
def canonical_mesh(vendor_dir: Path = VENDOR_DIR) -> CanonicalMesh:
    """The canonical mesh from the vendored JSON (written by scripts/vendor_face_mesh.py)."""
    raw = json.loads((vendor_dir / MESH_JSON).read_text("utf-8"))
    return CanonicalMesh(
        positions=tuple((p[0], p[1], p[2]) for p in raw["positions"]),
        uvs=tuple((u[0], u[1]) for u in raw["uvs"]),
        triangles=tuple((t[0], t[1], t[2]) for t in raw["triangles"]),
        procrustes={int(k): float(w) for k, w in raw["procrustes"].items()},
    )
