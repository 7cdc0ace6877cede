"""Builders of the real wire formats, for the face simulator and end-to-end tests.

They mirror the parsers in :mod:`livelink` and :mod:`facecapturex`; the parsers' own tests
check against packets assembled independently from protocols.md, not only against these.
"""

from __future__ import annotations

import struct
from collections.abc import Iterable, Mapping, Sequence

import numpy as np
import numpy.typing as npt

from chameleons.worker.frames import BLENDSHAPE_NAMES, N_BLENDSHAPES, F32Array, swift_raw_name
from chameleons.worker.ingest.livelink import (
    DEFAULT_ROTATION_FACTOR,
    LIVELINK_VALUE_COUNT,
    LIVELINK_VERSION,
)
from chameleons.worker.ingest.rotation import F64Array, rotation_matrix

DEFAULT_DEVICE_ID = "6F9619FF-8B86-D011-B42D-00C04FC964FF"  # 36 bytes, like a real UUID
DEFAULT_FACE_DISTANCE_M = 0.4


def livelink_values(
    blendshapes: npt.ArrayLike,
    head_deg: npt.ArrayLike = (0.0, 0.0, 0.0),
    eyes_deg: npt.ArrayLike = (0.0,) * 6,
    *,
    rotation_factor: float = DEFAULT_ROTATION_FACTOR,
) -> F32Array:
    """The 61 wire values: blendshapes as given, rotations converted from degrees."""
    shapes = np.asarray(blendshapes, dtype=np.float64).reshape(N_BLENDSHAPES)
    rotations = np.concatenate(
        [np.asarray(head_deg, float).reshape(3), np.asarray(eyes_deg, float).reshape(6)]
    )
    return np.concatenate([shapes, rotations / rotation_factor]).astype(np.float32)


def build_livelink_packet(
    values: npt.ArrayLike,
    *,
    frame_number: int = 0,
    subframe: float = 0.0,
    rate: tuple[int, int] = (60, 1),
    device_id: str = DEFAULT_DEVICE_ID,
    subject: str = "iPhone",
) -> bytes:
    """A Live Link Face v6 datagram carrying 61 wire values (see :func:`livelink_values`)."""
    wire = np.asarray(values, dtype=">f4").reshape(LIVELINK_VALUE_COUNT)
    device, name = device_id.encode(), subject.encode()
    head = struct.pack(
        f">Bi{len(device)}si{len(name)}s", LIVELINK_VERSION, len(device), device, len(name), name
    )
    timing = struct.pack(">ifiiB", frame_number, subframe, rate[0], rate[1], LIVELINK_VALUE_COUNT)
    return head + timing + wire.tobytes()


def face_transform(
    head_deg: Sequence[float], distance_m: float = DEFAULT_FACE_DISTANCE_M
) -> F64Array:
    """Camera-from-face 4x4 transform: the face ``distance_m`` in front of the camera, turned
    by yaw/pitch/roll (see :mod:`rotation`)."""
    transform = np.eye(4)
    transform[:3, :3] = rotation_matrix(*head_deg)
    transform[:3, 3] = (0.0, 0.0, -distance_m)
    return transform


def _numbers(values: Iterable[float]) -> str:
    return ":".join(f"{float(v):.7g}" for v in values)


def format_mesh(mesh: npt.ArrayLike) -> str:
    """Mesh vertices as ``x:y:z`` fields joined by ``~`` (format once, send many times)."""
    return "~".join(_numbers(v) for v in np.asarray(mesh, dtype=np.float64).reshape(-1, 3))


def build_facecapturex_frame(
    blendshapes: Mapping[str, float] | npt.ArrayLike,
    head_deg: Sequence[float] = (0.0, 0.0, 0.0),
    *,
    camera: npt.ArrayLike | None = None,
    mesh: npt.ArrayLike | str | None = None,
    timestamp: float | None = None,
    include_tongue: bool = True,
) -> bytes:
    """One FaceCaptureX text frame, terminated by ``a``.

    ``blendshapes``: 52 canonical-order values or a mapping of raw names to values (sent in
    the mapping's order, names as given). ``camera`` is the world-from-camera 4x4 (identity by
    default); the face anchor is sent as ``camera @ face_transform(head_deg)``, so the
    receiver's inverse(camera) x face recovers ``head_deg``. Matrices go column by column.
    """
    cam = np.eye(4) if camera is None else np.asarray(camera, dtype=np.float64).reshape(4, 4)
    face = cam @ face_transform(head_deg)
    fields = [] if timestamp is None else [f"{timestamp:.6f}"]
    fields += [_numbers(cam.flatten(order="F")), _numbers(face.flatten(order="F"))]
    if isinstance(mesh, str):
        fields.append(mesh)
    elif mesh is not None:
        fields.append(format_mesh(mesh))
    if isinstance(blendshapes, Mapping):
        pairs = list(blendshapes.items())
    else:
        values = np.asarray(blendshapes, dtype=np.float64).reshape(N_BLENDSHAPES)
        pairs = [
            (swift_raw_name(n), float(v)) for n, v in zip(BLENDSHAPE_NAMES, values, strict=True)
        ]
        if not include_tongue:
            pairs = [p for p in pairs if p[0] != "tongueOut"]
    fields += [f"{name}:{value:.7g}" for name, value in pairs]
    return ("~".join(fields) + "a").encode()


FACECAPTUREX_END = b"z"
