"""Where files live on this machine, for paths that cross from the server to a worker.

The server and a worker may run on different machines, each with its own install: an
absolute server path means nothing on a booth PC. So the server names a shipped prompt file
relative to the prompts folder (``"prompts:_natural/demo-natural.npz"``) and a recording
relative to the data directory (``"data:recordings/study-1/..."``; production shares the
recordings volume at the same relative place), and each side resolves the marker against
its own folders with :func:`resolve_marked_path`. Unmarked paths are used as they are.

Pure path logic at the bottom of the layers (it imports nothing of the project): the
server, the prompt catalogue and the worker all import it. ``chameleons.prompts.locations``
re-exports it.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

MANIFEST_NAME = "manifest.csv"  # an actor's folder holds one (format: prompts/README.md)
REPOSITORY_PROMPTS = Path(__file__).resolve().parents[1] / "prompts"
PROMPTS_MARKER = "prompts:"
DATA_MARKER = "data:"


def prompts_root(settings: Any) -> Path:
    """The prompts folder in use: ``settings.prompts_dir`` when set, else
    ``<data_dir>/prompts`` when it holds actors, else the repository's ``prompts/``."""
    configured = getattr(settings, "prompts_dir", None)
    if configured:
        return Path(configured)
    data_dir = getattr(settings, "data_dir", None)
    if data_dir is not None and actor_directories(Path(data_dir) / "prompts"):
        return Path(data_dir) / "prompts"
    return REPOSITORY_PROMPTS


def actor_directories(root: Path) -> list[Path]:
    """Sub-directories of ``root`` holding a manifest, sorted; ``_``/``.`` names are skipped."""
    if not root.is_dir():
        return []
    return sorted(
        path
        for path in root.iterdir()
        if path.is_dir()
        and not path.name.startswith(("_", "."))
        and (path / MANIFEST_NAME).is_file()
    )


def _relative_to(path: Path, root: Path) -> str | None:
    try:
        return path.resolve().relative_to(root.resolve()).as_posix()
    except ValueError:
        return None


def marked_path(path: Path, settings: Any) -> str:
    """``path`` as a worker on another machine can find it: marked relative to the prompts
    folder (in use, else the repository's) or the data directory, else absolute."""
    for marker, root in (
        (PROMPTS_MARKER, prompts_root(settings)),
        (PROMPTS_MARKER, REPOSITORY_PROMPTS),
        (DATA_MARKER, Path(getattr(settings, "data_dir", None) or "data")),
    ):
        relative = _relative_to(path, root)
        if relative is not None:
            return marker + relative
    return str(path.resolve())


def resolve_marked_path(value: str, settings: Any) -> Path:
    """The local file a (possibly marked) path names. A ``prompts:`` file missing from the
    prompts folder in use falls back to the repository's (the shipped demo clip)."""
    if value.startswith(PROMPTS_MARKER):
        relative = value.removeprefix(PROMPTS_MARKER)
        in_use = prompts_root(settings) / relative
        return in_use if in_use.exists() else REPOSITORY_PROMPTS / relative
    if value.startswith(DATA_MARKER):
        data_dir = Path(getattr(settings, "data_dir", None) or "data")
        return data_dir / value.removeprefix(DATA_MARKER)
    return Path(value)
