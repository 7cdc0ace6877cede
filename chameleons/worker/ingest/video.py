"""Frames from a video file or a camera, through PyAV (FFmpeg): what the Python tracker reads.

:func:`video_frames` reads a file (MP4/H.264, WebM/VP8/VP9, MOV, MJPEG AVI, whatever the
FFmpeg inside PyAV decodes); :func:`camera_frames` opens a local camera (Linux ``v4l2``
``/dev/video0``, macOS ``avfoundation`` ``0``, Windows ``dshow`` ``video=<name>``), or a
video file standing in for one (paced at its own frame rate, for tests and rehearsals).
Each frame is RGB (H x W x 3, uint8) with its time in seconds from the stream's start.
Anything FFmpeg cannot open is a :class:`VideoError` with one sentence.
"""

from __future__ import annotations

import platform
import time
from collections.abc import Iterator
from dataclasses import dataclass
from fractions import Fraction
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

CAMERA_FORMATS = {"Linux": "v4l2", "Darwin": "avfoundation", "Windows": "dshow"}


class VideoError(ValueError):
    """A video or camera that cannot be read; the message is one sentence."""


@dataclass(frozen=True, slots=True)
class VideoFrame:
    time: float  # seconds from the stream's start (file) or the first frame (camera)
    image: npt.NDArray[np.uint8]  # RGB, H x W x 3


@dataclass(frozen=True, slots=True)
class VideoInfo:
    frame_rate: float  # frames per second (the stream's average; 0 when unknown)
    width: int
    height: int
    codec: str


def _open(source: str, **options: Any) -> Any:
    import av  # imported here: ``chameleons --help`` and the server need no FFmpeg

    try:
        return av.open(source, **options)
    except (av.FFmpegError, OSError, ValueError) as exc:
        raise VideoError(f"{source}: not a video FFmpeg can read ({_reason(exc)})") from exc


def _reason(exc: BaseException) -> str:
    return str(getattr(exc, "strerror", None) or exc).strip().rstrip(".") or type(exc).__name__


def _info(stream: Any) -> VideoInfo:
    rate = stream.average_rate or stream.guessed_rate or Fraction(0)
    context = stream.codec_context
    return VideoInfo(float(rate), int(context.width), int(context.height), str(context.name))


def video_info(path: str | Path) -> VideoInfo:
    container = _open(str(path))
    try:
        if not container.streams.video:
            raise VideoError(f"{path}: has no video stream")
        return _info(container.streams.video[0])
    finally:
        container.close()


def _decode(container: Any, source: str) -> Iterator[VideoFrame]:
    import av

    if not container.streams.video:
        raise VideoError(f"{source}: has no video stream")
    stream = container.streams.video[0]
    stream.thread_type = "AUTO"
    start = float(stream.start_time * stream.time_base) if stream.start_time is not None else None
    count = 0
    try:
        for frame in container.decode(stream):
            if frame.time is None:
                continue
            if start is None:
                start = float(frame.time)
            count += 1
            yield VideoFrame(float(frame.time) - start, frame.to_ndarray(format="rgb24"))
    except av.FFmpegError as exc:
        if not count:
            raise VideoError(f"{source}: not a video FFmpeg can read ({_reason(exc)})") from exc
        # A file cut short: keep what was decoded (the frames are written already).


def video_frames(path: str | Path) -> Iterator[VideoFrame]:
    """Every frame of a video file, in order."""
    container = _open(str(path))
    try:
        yield from _decode(container, str(path))
    finally:
        container.close()


def camera_frames(device: str, *, size: str = "640x480", rate: int = 30,
                  realtime: bool = True) -> Iterator[VideoFrame]:  # fmt: skip
    """A camera's frames, or a video file's paced at its own rate (``realtime``) as a
    camera would deliver them. Times are from the first frame."""
    if Path(device).is_file():
        first: float | None = None
        for frame in video_frames(device):
            now = time.monotonic()
            first = now - frame.time if first is None else first
            if realtime:
                time.sleep(max(0.0, first + frame.time - now))
            yield frame
        return
    kind = CAMERA_FORMATS.get(platform.system())
    options = {"framerate": str(rate), "video_size": size}
    container = _open(device, format=kind, options=options) if kind else _open(device)
    try:
        yield from _decode(container, device)
    finally:
        container.close()
