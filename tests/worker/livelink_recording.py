"""A Live Link Face recording generated in the app's exact UDP format (protocols.md 2a, as
Unreal's receiver and LLV read it): no public recording is shipped (LLV's BSD-licensed
``dao.gesichter`` was checked against, see docs/livelink.md, but is not copied here).

What the app sends and this reproduces: packet version 6; the device id as an upper-case
UUID string (36 bytes); the subject name (the app's default is the device name); the frame
number on a 60 fps timecode clock (frames since local midnight) with a sub-frame; 61
big-endian floats: 52 blendshapes 0..1 and nine rotations in **radians**; and, while the
phone sees nobody, header-only packets. Not a test module.
"""

from __future__ import annotations

import math
import struct
from dataclasses import dataclass

import numpy as np

from chameleons.worker.frames import BLENDSHAPE_INDEX, N_BLENDSHAPES

DEVICE_ID = "2C7A4D1E-93B5-4F0A-8E61-5D2B7C9A0F34"
SUBJECT = "iPhone"
FPS = 60
START_FRAME = (14 * 3600 + 3 * 60 + 59) * FPS  # 14:03:59:00 on the timecode clock


@dataclass(frozen=True)
class Recording:
    packets: list[bytes]
    yaw_deg: list[float | None]  # what each packet means (None: no face)
    pitch_deg: list[float | None]


def _header(frame: int) -> bytes:
    device, subject = DEVICE_ID.encode(), SUBJECT.encode()
    return (struct.pack(f">Bi{len(device)}si{len(subject)}s", 6, len(device), device,
                        len(subject), subject)
            + struct.pack(">ifii", START_FRAME + frame, 0.0, FPS, 1))  # fmt: skip


def pose_packet(frame: int, yaw: float, pitch: float, jaw: float = 0.2,
                brow: float = 0.0) -> bytes:  # fmt: skip
    """One packet of the app: timecode ``frame`` frames after 14:03:59:00, head in degrees
    (sent as radians), ``brow`` the brow raise (browInnerUp and both outer brows)."""
    values = np.zeros(61, dtype=">f4")
    values[BLENDSHAPE_INDEX["jawOpen"]] = jaw
    for name in ("browInnerUp", "browOuterUpLeft", "browOuterUpRight"):
        values[BLENDSHAPE_INDEX[name]] = brow
    values[N_BLENDSHAPES : N_BLENDSHAPES + 3] = [math.radians(yaw), math.radians(pitch), 0.0]
    return _header(frame) + struct.pack(">B", 61) + values.tobytes()



def head_turn_then_nod(turn_deg: float = 40.0, nod_deg: float = 15.0) -> Recording:
    """Still, a smooth turn to ``turn_deg`` (subject's left: yaw > 0 turns the nose to the
    viewer's right) and back, a nod of ``nod_deg`` (pitch > 0: chin down), the face lost
    for a moment, then still again: about 4 s at 60 fps."""
    packets: list[bytes] = []
    yaws: list[float | None] = []
    pitches: list[float | None] = []
    frame = 0

    def add(yaw: float, pitch: float) -> None:
        nonlocal frame
        packets.append(pose_packet(frame, yaw, pitch))
        yaws.append(yaw)
        pitches.append(pitch)
        frame += 1

    for _ in range(30):
        add(0.0, 0.0)
    for k in range(90):  # 1.5 s: out and back
        add(turn_deg * math.sin(math.pi * k / 89), 0.0)
    for k in range(60):  # 1 s nod
        add(0.0, nod_deg * math.sin(math.pi * k / 59))
    for _ in range(20):  # the participant leaves the camera's view for a third of a second
        packets.append(_header(frame))
        yaws.append(None)
        pitches.append(None)
        frame += 1
    for _ in range(40):
        add(0.0, 0.0)
    return Recording(packets, yaws, pitches)
