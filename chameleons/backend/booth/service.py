"""What the booth flow decides, without the bridge: where an interaction's recordings go, how
the worker's files become Recording rows, and which clip ``natural`` replays.

Recordings are written by the worker to ``<data dir>/recordings/study-<id>/session-<id>/``
(absolute on the wire). The embedded worker shares the server's disk; a remote worker must
see the same directory under the same path — production mounts one shared volume at the
data directory of both (the ``recordings`` volume in docker-compose.yml). A file the server
cannot see is still indexed, from the worker's own frame count, with size 0.

``natural`` replays, in this order: a clip the lab configured
(``app.state.behaviour_params["natural"]["path"]``); the yoked control — the participant
stream of the most recent finished ``copy``/``still`` interaction of another participant of
this study, at least ``min_yoked_frames`` long; else the demo clip
(``<prompts>/_natural/demo-natural.npz``, shipped in the repository's ``prompts/``). The choice is
made once per interaction and logged (``behaviour.natural_source``), so every later set-up of
that interaction replays the same recording and the export can say which one it was. The path
goes to the worker marked (``prompts:_natural/demo-natural.npz``, ``data:recordings/...``) so
a worker on a booth PC resolves it against its own install (``chameleons.prompts.locations``).
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
from chameleons.backend.events import repository as events
from chameleons.backend.models import Recording
from chameleons.backend.withdrawal.files import RECORDINGS_DIR, recording_file
from chameleons.prompts.locations import (
    REPOSITORY_PROMPTS,
    marked_path,
    prompts_root,
    resolve_marked_path,
)
from chameleons.worker.recording import RecordingError, journal_path, recover_recording

log = logging.getLogger(__name__)
DEMO_CLIP_NAME = Path("_natural") / "demo-natural.npz"  # made by scripts/make_demo_natural_clip.py
DEMO_NATURAL_CLIP = REPOSITORY_PROMPTS / DEMO_CLIP_NAME
STREAMS = ("participant", "agent")
PARQUET = ".parquet"


@dataclass(frozen=True)
class BoothConfig:
    """Knobs of the booth flow (``app.state.booth_config`` overrides the defaults)."""

    min_yoked_frames: int = 1800  # 30 s at the phone's 60 fps
    demo_clip: Path | None = None  # None: <prompts>/_natural/demo-natural.npz
    record: bool = True  # start/stop the worker's recording with each interaction


def config_of(state: Any) -> BoothConfig:
    config = getattr(state, "booth_config", None)
    return config if isinstance(config, BoothConfig) else BoothConfig()


def data_dir_of(state: Any) -> Path:
    return Path(state.settings.data_dir)


def demo_clip_of(state: Any) -> Path:
    """The configured demo clip, else the one in the prompts folder in use, else the one
    shipped in the repository."""
    configured = config_of(state).demo_clip
    if configured is not None:
        return configured
    in_use = prompts_root(state.settings) / DEMO_CLIP_NAME
    return in_use if in_use.is_file() else DEMO_NATURAL_CLIP


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


def files_in(directory: Path, interaction_id: int) -> dict[Path, str]:
    """The interaction's recordings in ``directory`` (Parquet path -> stream); a journal a
    crash left behind is recovered into its Parquet file first."""
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
        if target.exists():
            found[target] = match.group(1)
    return found


def file_facts(path: Path) -> tuple[int, int] | None:
    """(frames, bytes) of a Parquet recording the server can read; None when it cannot."""
    if not path.exists() and journal_path(path).exists():
        try:
            recover_recording(path)
        except RecordingError:
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
) -> list[Recording]:
    """Index the files the worker reported (``{"files": {stream: path}, "frames": {...}}``)
    and, with ``scan``, every file of the interaction in that directory. Files already
    indexed are skipped, so the same stop may be reported twice. Returns the new rows."""
    candidates = dict(files_in(scan, interaction_id)) if scan is not None else {}
    reported = reported or {}
    worker_frames: dict[str, int] = {}
    for stream, raw in (reported.get("files") or {}).items():
        if stream in STREAMS and isinstance(raw, str) and raw.endswith(PARQUET):
            path = recording_file(data_dir, raw)
            candidates.setdefault(path, stream)
            count = (reported.get("frames") or {}).get(stream)
            worker_frames[str(path)] = int(count) if isinstance(count, int) else 0
    known = repository.indexed_paths(db, interaction_id)
    added: list[Recording] = []
    for path, stream in sorted(candidates.items()):
        stored = stored_path(data_dir, path)
        if stored in known:
            continue
        facts = file_facts(path)
        frames, size = facts if facts is not None else (worker_frames.get(str(path), 0), 0)
        row = Recording(
            interaction_id=interaction_id, stream=stream, path=stored, frames=frames,
            size_bytes=size,
        )  # fmt: skip
        db.add(row)
        known.add(stored)
        added.append(row)
    db.flush()
    return added


def describe(rows: list[Recording]) -> list[dict[str, Any]]:
    return [
        {"id": r.id, "stream": r.stream, "path": r.path, "frames": r.frames,
         "size_bytes": r.size_bytes}
        for r in rows
    ]  # fmt: skip


# --- behaviour parameters ----------------------------------------------------------------------
def behaviour_params(
    db: Session, state: Any, interaction_id: int, condition: str
) -> tuple[dict[str, Any] | None, dict[str, Any] | None]:
    """The ``set_behaviour`` parameters for ``condition`` in this interaction, and (for
    ``natural``) the source it replays, to log with the set-up."""
    configured = (getattr(state, "behaviour_params", None) or {}).get(condition)
    if condition != "natural":
        return (dict(configured) if configured else None), None
    params = dict(configured or {})
    if isinstance(params.get("path"), str) and params["path"]:
        return params, {"source": "configured", "path": params["path"]}
    source = natural_source(db, state, interaction_id)
    if source.get("path"):
        params["path"] = source["path"]
    return params or None, source


def natural_source(db: Session, state: Any, interaction_id: int) -> dict[str, Any]:
    """The clip ``natural`` replays in this interaction: chosen once, then the same."""
    chosen = repository.chosen_natural_source(db, interaction_id)
    if chosen is not None:
        path = chosen.payload.get("path")
        if not path or resolve_marked_path(str(path), state.settings).is_file():
            return dict(chosen.payload)
    located = repository.locate(db, interaction_id)
    if located is None:
        return {"source": "none", "reason": f"there is no interaction {interaction_id}"}
    source = _choose(db, state, located)
    events.record(
        db, repository.NATURAL_SOURCE, source="server", study_id=located.session.study_id,
        session_id=located.session.id, interaction_id=interaction_id, payload=source,
    )  # fmt: skip
    return source


def _choose(db: Session, state: Any, located: repository.Located) -> dict[str, Any]:
    config, data_dir = config_of(state), data_dir_of(state)
    candidates = repository.yoked_candidates(
        db, located.interaction, located.session, config.min_yoked_frames
    )
    for recording in candidates:
        path = recording_file(data_dir, recording.path)
        if path.is_file():
            return {
                "source": "yoked", "path": marked_path(path, state.settings),
                "recording_id": recording.id,
                "from_interaction_id": recording.interaction_id, "frames": recording.frames,
            }  # fmt: skip
    demo = demo_clip_of(state)
    if demo.is_file():
        return {"source": "demo", "path": marked_path(demo, state.settings)}
    return {"source": "none", "reason": f"no yoked recording and no demo clip {demo}"}
