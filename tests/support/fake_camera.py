"""Chromium's fake camera fed from a real face photo: a Y4M file (``--use-file-for-fake-
video-capture``) made from tests/support/faces.py's scenes."""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path

import numpy as np
import numpy.typing as npt
from PIL import Image

from tests.support.browser import chromium_path
from tests.support.head3d import WEBGL_ARGS


def write_y4m(path: Path, frames: Iterable[npt.NDArray[np.uint8]], rate: int = 30) -> Path:
    """RGB frames (H x W x 3, even sizes) as 4:2:0 Y4M, full-range BT.601 (JPEG's YCbCr)."""
    with path.open("wb") as out:
        for index, rgb in enumerate(frames):
            height, width = rgb.shape[:2]
            if index == 0:
                out.write(f"YUV4MPEG2 W{width} H{height} F{rate}:1 Ip A1:1 C420jpeg\n".encode())
            ycc = np.asarray(Image.fromarray(rgb).convert("YCbCr"), dtype=np.float32)
            out.write(b"FRAME\n")
            out.write(ycc[:, :, 0].astype(np.uint8).tobytes())
            for plane in (1, 2):
                channel = ycc[:, :, plane]
                halves = channel.reshape(height // 2, 2, width // 2, 2).mean(axis=(1, 3))
                out.write(np.round(halves).astype(np.uint8).tobytes())
    return path


def camera_args(video: Path) -> list[str]:
    """Chromium flags: software WebGL, and a camera that plays ``video`` (granted)."""
    return [*WEBGL_ARGS, "--use-fake-device-for-media-stream", "--use-fake-ui-for-media-stream",
            f"--use-file-for-fake-video-capture={video}"]  # fmt: skip


def chromium() -> str | None:
    return chromium_path()
