"""Video files made with PyAV from the real face photos (tests/support/faces.py)."""

from __future__ import annotations

from collections.abc import Iterable
from fractions import Fraction
from pathlib import Path

import av
import numpy as np
import numpy.typing as npt

# container suffix -> (codec, pixel format)
CONTAINERS = {
    "mp4": ("libx264", "yuv420p"),
    "webm": ("libvpx-vp9", "yuv420p"),
    "mov": ("libx264", "yuv420p"),
    "avi": ("mjpeg", "yuvj420p"),
}


def write_video(path: Path, frames: Iterable[npt.NDArray[np.uint8]], rate: int = 30,
                codec: str | None = None) -> Path:  # fmt: skip
    """Encode RGB frames into ``path``; the container comes from the suffix."""
    default_codec, pixel_format = CONTAINERS[path.suffix.lstrip(".")]
    with av.open(str(path), "w") as container:
        stream = container.add_stream(codec or default_codec, rate=Fraction(rate))
        assert isinstance(stream, av.VideoStream)
        stream.pix_fmt = pixel_format if (codec or default_codec) != "libvpx" else "yuv420p"
        first = True
        for image in frames:
            if first:
                stream.height, stream.width = image.shape[:2]
                first = False
            for packet in stream.encode(av.VideoFrame.from_ndarray(image, format="rgb24")):
                container.mux(packet)
        for packet in stream.encode():
            container.mux(packet)
    return path
