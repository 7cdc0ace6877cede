"""The video files: one WebM per recording, ``<data dir>/video/session-<id>/video-<n>.webm``,
the chunks appended in order. ``MediaRecorder``'s timeslices are consecutive pieces of one
WebM stream (the first carries the EBML header), so the file plays as it grows."""

from __future__ import annotations

import os
import shutil
from pathlib import Path

FOLDER = "video"
EBML_MAGIC = b"\x1a\x45\xdf\xa3"  # the EBML header's id: every WebM file begins with it


def session_folder(data_dir: Path, session_id: int) -> Path:
    return data_dir / FOLDER / f"session-{session_id}"


def relative_path(session_id: int, video_id: int) -> str:
    return f"{FOLDER}/session-{session_id}/video-{video_id}.webm"


def append(path: Path, expected_size: int, data: bytes) -> None:
    """Append ``data`` where the index says the file ends (``expected_size``): bytes a crash
    left after the last indexed chunk are cut off first. Flushed to the disk before the
    chunk is indexed, so a crash loses at most the chunk being written."""
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("a+b") as out:
        if out.seek(0, os.SEEK_END) != expected_size:
            out.truncate(expected_size)
            out.seek(expected_size)
        out.write(data)
        out.flush()
        os.fsync(out.fileno())


def delete_session_videos(data_dir: Path, session_id: int) -> int:
    """Delete a session's video folder; returns how many files it held."""
    folder = session_folder(data_dir, session_id)
    if not folder.is_dir() or folder.is_symlink():
        return 0
    count = sum(1 for path in folder.rglob("*") if path.is_file())
    shutil.rmtree(folder)
    return count
