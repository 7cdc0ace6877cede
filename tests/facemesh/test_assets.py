"""The vendored face mesh package: its packed models and its canonical face geometry."""

from __future__ import annotations

import json

from chameleons.facemesh.assets import (
    GEOMETRY_FILE,
    MESH_JSON,
    VENDOR_DIR,
    canonical_mesh,
    canonical_mesh_json,
    packed_files,
    read_packed,
)


def test_the_packed_models_are_the_ones_mediapipe_documents() -> None:
    files = packed_files()
    assert set(files) == {
        "face_landmark.tflite", "face_landmark_with_attention.tflite",
        "face_detection_short_range.tflite", GEOMETRY_FILE,
    }  # fmt: skip
    for name in ("face_landmark.tflite", "face_detection_short_range.tflite"):
        assert read_packed(name)[4:8] == b"TFL3", name  # the FlatBuffer file identifier


def test_the_canonical_mesh_has_mediapipe_s_published_size_and_symmetry() -> None:
    mesh = canonical_mesh()
    # 468 vertices and 898 triangles: mediapipe/modules/face_geometry/data/
    # canonical_face_model.obj; vertex 1 is the nose tip, on the face's midline.
    assert len(mesh.positions) == len(mesh.uvs) == 468
    assert len(mesh.triangles) == 898
    assert all(0 <= i < 468 for tri in mesh.triangles for i in tri)
    assert abs(mesh.positions[1][0]) < 1e-6
    assert mesh.positions[1][2] > 5
    # Left/right pairs mirror each other: outer eye corners 33 and 263.
    (xl, yl, zl), (xr, yr, zr) = mesh.positions[33], mesh.positions[263]
    assert abs(xl + xr) < 1e-3
    assert abs(yl - yr) < 1e-3
    assert abs(zl - zr) < 1e-3
    assert 20 < len(mesh.procrustes) < 468
    assert all(w > 0 for w in mesh.procrustes.values())


def test_the_vendored_json_is_not_stale() -> None:
    """scripts/vendor_face_mesh.py wrote the JSON from the packed geometry; decoding it
    again gives the same file."""
    on_disk = json.loads((VENDOR_DIR / MESH_JSON).read_text("utf-8"))
    assert on_disk == json.loads(canonical_mesh_json())
