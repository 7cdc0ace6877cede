"""Where recording files live: absolute paths as workers wrote them, relative ones under
the data directory."""

from __future__ import annotations

from pathlib import Path


def recording_file(data_dir: Path, stored: str) -> Path:
    path = Path(stored)
    return path if path.is_absolute() else data_dir / path


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
