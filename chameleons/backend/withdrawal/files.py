"""Where recording files live, and finding every file of a withdrawn participant.

Indexed recordings are absolute paths as workers wrote them, or relative to the data
directory. Workers may also leave files the index does not know: the crash-safe journal
next to a recording (``<name>.parquet.journal``) and a recording whose indexing a crash
prevented. Those follow the worker's naming, ``interaction-<id>[-partN]-<stream>.parquet``,
and are looked for beside the indexed files and under ``<data dir>/recordings``. Nothing
outside that folder is ever deleted (:func:`in_recordings`), whatever the index says.
"""

from __future__ import annotations

import re
from collections.abc import Iterable
from pathlib import Path

JOURNAL_SUFFIX = ".journal"
RECORDINGS_DIR = "recordings"


def recording_file(data_dir: Path, stored: str) -> Path:
    path = Path(stored)
    return path if path.is_absolute() else data_dir / path


def in_recordings(data_dir: Path, path: Path) -> bool:
    """Whether ``path`` lies inside ``<data dir>/recordings`` once symlinks (and ``..``) are
    resolved on both sides. Recordings are only ever written there (the server names the
    folder); a path elsewhere came from a forged or broken message (the worker link runs
    without authentication on loopback by default) and is never indexed nor deleted."""
    root = (data_dir / RECORDINGS_DIR).resolve()
    try:
        resolved = path.resolve()
    except (OSError, RuntimeError):  # a symlink loop
        return False
    return resolved != root and resolved.is_relative_to(root)


def _worker_name(interaction_ids: Iterable[int]) -> re.Pattern[str]:
    ids = "|".join(str(i) for i in sorted(set(interaction_ids))) or "(?!)"
    return re.compile(
        rf"^interaction-(?:{ids})(?:-part\d+)?-(?:participant|agent)\.parquet(?:\.journal)?$"
    )


def files_of(indexed: list[Path], interaction_ids: list[int], data_dir: Path) -> list[Path]:
    """The indexed files, their journals, and unindexed worker files of these interactions."""
    found = set(indexed) | {p.with_name(p.name + JOURNAL_SUFFIX) for p in indexed}
    pattern = _worker_name(interaction_ids)
    for directory in {p.parent for p in indexed}:
        if directory.is_dir():
            found.update(p for p in directory.iterdir() if pattern.match(p.name))
    root = data_dir / RECORDINGS_DIR
    if root.is_dir() and interaction_ids:
        found.update(p for p in root.rglob("interaction-*") if pattern.match(p.name))
    return sorted(found)


def delete_files(paths: list[Path], data_dir: Path) -> tuple[int, list[Path]]:
    """Delete the files (a missing one is fine: a rerun after a crash finds some gone), then
    any directory left empty inside the data directory. A path outside the recordings
    folder (:func:`in_recordings`) is not touched. Returns how many files existed and were
    deleted, and the existing files refused."""
    outside = [path for path in paths if not in_recordings(data_dir, path)]
    refused = [path for path in outside if path.exists()]
    deleted = 0
    for path in paths:
        if path in outside:
            continue
        try:
            path.unlink()
            deleted += 1
        except FileNotFoundError:
            continue
    root = data_dir.resolve()
    inside = {p.parent.resolve() for p in paths if p not in outside}
    for directory in sorted(inside, key=lambda d: -len(d.parts)):
        _remove_empty_dirs(directory, root)
    return deleted, refused


def _remove_empty_dirs(directory: Path, root: Path) -> None:
    while directory != root and directory.is_relative_to(root):
        try:
            directory.rmdir()
        except OSError:  # not empty, or already gone
            return
        directory = directory.parent
