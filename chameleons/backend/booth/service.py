"""What the booth flow decides, without the bridge: where an interaction's recordings go and
how the worker's files become Recording rows (the behaviour it runs: ``behaviour.py``).

Recordings are written by the worker to ``<data dir>/recordings/study-<id>/session-<id>/``
(absolute on the wire). The embedded worker shares the server's disk; a remote worker must
see the same directory under the same path — production mounts one shared volume at the
data directory of both (the ``recordings`` volume in docker-compose.yml). A file the server
cannot see is still indexed, from the worker's own frame count, with size 0. A reported
path outside ``<data dir>/recordings`` (symlinks resolved) or not named for its interaction
is never indexed, whatever the message says: the worker link may run unauthenticated on
loopback, and what is indexed is what a withdrawal deletes.
"""

from __future__ import annotations

import logging
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pyarrow as pa
import pyarrow.parquet as pq
from sqlalchemy.orm import Session

from chameleons.backend.booth import repository
from chameleons.backend.booth.face_source import dominant_source, note_face_source
from chameleons.backend.models import Recording
from chameleons.backend.withdrawal.files import RECORDINGS_DIR, in_recordings, recording_file
from chameleons.worker.recording import (
    RecordingError,
    journal_path,
    recover_recording,
    write_problem,
)

log = logging.getLogger(__name__)
STREAMS = ("participant", "agent")
PARQUET = ".parquet"


@dataclass(frozen=True)
class BoothConfig:
    """Knobs of the booth flow (``app.state.booth_config`` overrides the defaults)."""

    record: bool = True  # start/stop the worker's recording with each interaction


def config_of(state: Any) -> BoothConfig:
    config = getattr(state, "booth_config", None)
    return config if isinstance(config, BoothConfig) else BoothConfig()


def data_dir_of(state: Any) -> Path:
    return Path(state.settings.data_dir)


# --- recordings --------------------------------------------------------------------------------
def recording_directory(data_dir: Path, study_id: int, session_id: int) -> Path:
    return data_dir.resolve() / RECORDINGS_DIR / f"study-{study_id}" / f"session-{session_id}"


def stored_path(data_dir: Path, path: Path) -> str:
    """Relative to the data directory when inside it (the data survives a move), else as is."""
    root = data_dir.resolve()
    resolved = path.resolve() if path.is_absolute() else path
    return str(resolved.relative_to(root)) if resolved.is_relative_to(root) else str(path)


def _interaction_files(interaction_id: int) -> re.Pattern[str]:
    return re.compile(
        rf"^interaction-{interaction_id}(?:-part\d+)?-(participant|agent)\.parquet(?:\.journal)?$"
    )


def files_in(
    directory: Path, interaction_id: int, problems: list[str] | None = None
) -> dict[Path, str]:
    """The interaction's recordings in ``directory`` (Parquet path -> stream); a journal a
    crash left behind is recovered into its Parquet file first. A journal the disk does not
    let us recover (full, read-only) stays as it is and is told in ``problems``."""
    pattern = _interaction_files(interaction_id)
    found: dict[Path, str] = {}
    if not directory.is_dir():
        return found
    for entry in sorted(directory.iterdir()):
        match = pattern.match(entry.name)
        if match is None:
            continue
        target = entry.with_name(entry.name.removesuffix(".journal"))
        if entry != target and not target.exists():
            try:
                recover_recording(target)
            except RecordingError as exc:  # cut before its first chunk: nothing to keep
                log.warning("recording journal %s not recoverable: %s", entry, exc)
                continue
            except OSError as exc:
                _tell(problems, write_problem(exc, directory), entry)
                continue
        if target.exists():
            found[target] = match.group(1)
    return found


def _worker_file(data_dir: Path, path: Path, interaction_id: int) -> bool:
    """A file the worker can have written for this interaction: named for it, and inside
    the recordings folder with symlinks resolved (files.in_recordings)."""
    named = _interaction_files(interaction_id).match(path.name) is not None
    return named and in_recordings(data_dir, path)


def _tell(problems: list[str] | None, sentence: str, path: Path) -> None:
    log.warning("recording %s not indexed: %s", path, sentence)
    if problems is not None and sentence not in problems:
        problems.append(sentence)


def file_facts(path: Path, problems: list[str] | None = None) -> tuple[int, int] | None:
    """(frames, bytes) of a Parquet recording the server can read; None when it cannot."""
    if not path.exists() and journal_path(path).exists():
        try:
            recover_recording(path)
        except RecordingError:
            return None
        except OSError as exc:
            _tell(problems, write_problem(exc, path.parent), path)
            return None
    try:
        frames = pq.ParquetFile(path).metadata.num_rows
        return int(frames), path.stat().st_size
    except (OSError, pa.ArrowException):
        return None


def index_recordings(
    db: Session,
    interaction_id: int,
    data_dir: Path,
    reported: dict[str, Any] | None = None,
    scan: Path | None = None,
    problems: list[str] | None = None,
) -> list[Recording]:
    """Index the files the worker reported (``{"files": {stream: path}, "frames": {...}}``)
    and, with ``scan``, every file of the interaction in that directory. Files already
    indexed are skipped, so the same stop may be reported twice. Returns the new rows; what
    the disk did not allow is told in ``problems`` (sentences), never raised."""
    candidates = dict(files_in(scan, interaction_id, problems)) if scan is not None else {}
    reported = reported or {}
    worker_frames: dict[str, int] = {}
    for stream, raw in (reported.get("files") or {}).items():
        if stream in STREAMS and isinstance(raw, str) and raw.endswith(PARQUET):
            path = recording_file(data_dir, raw)
            candidates.setdefault(path, stream)
            count = (reported.get("frames") or {}).get(stream)
            worker_frames[str(path)] = int(count) if isinstance(count, int) else 0
    for path in [p for p in candidates if not _worker_file(data_dir, p, interaction_id)]:
        del candidates[path]  # whatever the message said: never indexed, so never deleted
        _tell(problems, f"A recording was reported at {path}, outside the data folder's "
              "recordings or not named for its interaction: not indexed.", path)  # fmt: skip
    known = repository.indexed_paths(db, interaction_id)
    added: list[Recording] = []
    for path, stream in sorted(candidates.items()):
        stored = stored_path(data_dir, path)
        if stored in known:
            continue
        facts = file_facts(path, problems)
        frames, size = facts if facts is not None else (worker_frames.get(str(path), 0), 0)
        row = Recording(
            interaction_id=interaction_id, stream=stream, path=stored, frames=frames,
            size_bytes=size,
        )  # fmt: skip
        if stream == "participant" and facts is not None:
            row.face_source, row.face_calibration = dominant_source(path)
        db.add(row)
        known.add(stored)
        added.append(row)
    note_face_source(db, interaction_id, added)
    db.flush()
    return added


def describe(rows: list[Recording]) -> list[dict[str, Any]]:
    return [
        {"id": r.id, "stream": r.stream, "path": r.path, "frames": r.frames,
         "size_bytes": r.size_bytes}
        for r in rows
    ]  # fmt: skip
