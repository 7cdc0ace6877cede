"""Where recording files live, and finding every file of a withdrawn participant.

Indexed recordings are absolute paths as workers wrote them, or relative to the data
directory. Workers may also leave files the index does not know: the crash-safe journal
next to a recording (``<name>.parquet.journal``) and a recording whose indexing a crash
prevented. Those follow the worker's naming, ``interaction-<id>[-partN]-<stream>.parquet``,
and are looked for beside the indexed files and under ``<data dir>/recordings``.
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


def delete_files(paths: list[Path], data_dir: Path) -> int:
    """Delete the files (a missing one is fine: a rerun after a crash finds some gone), then
    any directory left empty inside the data directory. Returns how many files existed."""
    deleted = 0
    for path in paths:
        try:
            path.unlink()
            deleted += 1
        except FileNotFoundError:
            continue
    root = data_dir.resolve()
    for directory in sorted({p.parent.resolve() for p in paths}, key=lambda d: -len(d.parts)):
        _remove_empty_dirs(directory, root)
    return deleted


def _remove_empty_dirs(directory: Path, root: Path) -> None:
    while directory != root and directory.is_relative_to(root):
        try:
            directory.rmdir()
        except OSError:  # not empty, or already gone
            return
        directory = directory.parent
