"""Which behaviour the worker runs for an interaction's condition, and what ``natural`` replays.

A condition runs the behaviour the study declares, with the study's parameters. For
``natural`` the study names the source (the condition's ``params.source``):

- ``clip`` (the paper's default): one fixed recording from the prompt catalogue, ``params.clip``
  (``demo-natural`` is ``<prompts>/_natural/demo-natural.npz``, shipped in the repository);
- ``yoked``: the participant stream of the most recent finished interaction of another
  participant of this study in a condition that does not replay a recording itself, at least
  ``params.yoked_min_seconds`` long. Until such a recording exists (the first participants)
  the clip is replayed, and the record says so;
- ``synthetic``: the face simulator (``params.seed``).

The choice is made once per interaction, logged (``behaviour.natural_source``) and written on
the interaction (``natural_source``, ``natural_recording``: exported, shown to the wizard), so
every later set-up of that interaction replays the same recording.

The shipped ``demo-natural`` clip is synthetic (the face simulator's, made by
``scripts/make_demo_natural_clip.py``), not a recording of a real conversation: a real study
records its own. A source that is that clip (recognised by its content, wherever it lies) is
marked ``synthetic_demo`` and said so in its description, and :func:`demo_clip_warning`
says so to the PI and the wizard before a real participant sees it. The path goes to the
worker marked (``prompts:_natural/demo-natural.npz``, ``data:recordings/...``) so a worker on
a booth PC resolves it against its own install (``chameleons.prompts.locations``).
"""

from __future__ import annotations

import functools
import hashlib
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from sqlalchemy.orm import Session

from chameleons.backend.booth import repository
from chameleons.backend.booth.service import data_dir_of
from chameleons.backend.events import repository as events
from chameleons.backend.studies.specs import spec_of
from chameleons.backend.withdrawal.files import recording_file
from chameleons.experiment.model import Study
from chameleons.prompts.locations import (
    REPOSITORY_PROMPTS,
    marked_path,
    prompts_root,
    resolve_marked_path,
)
from chameleons.worker.behaviours.copy_params import in_words, needs_seed

NATURAL = "natural"
COPY = "copy"
YOKED_COPY = "yoked_copy"
DEFAULT_CLIP = "demo-natural"  # the natural behaviour's default clip parameter
# <prompts>/_natural/<name>.npz; the demo clip is made by scripts/make_demo_natural_clip.py
NATURAL_CLIPS = Path("_natural")
PHONE_FPS = 60.0  # the capture apps' frame rate: yoked_min_seconds -> recorded frames
SYNTHETIC_DEMO_CLIP = REPOSITORY_PROMPTS / NATURAL_CLIPS / f"{DEFAULT_CLIP}.npz"


@dataclass(frozen=True)
class RobotBehaviour:
    """What the worker runs for a condition: the study's behaviour and parameters as the
    worker takes them, and (``natural`` only) the source it replays, to log and record."""

    name: str
    params: dict[str, Any]
    natural_source: dict[str, Any] | None = None


def robot_behaviour(db: Session, state: Any, interaction_id: int, condition: str) -> RobotBehaviour:
    """The behaviour the study declares for ``condition`` in this interaction."""
    located = repository.locate(db, interaction_id)
    if located is None:
        raise LookupError(f"there is no interaction {interaction_id}")
    spec = spec_of(located.study(db))
    declared = spec.condition(condition)
    if declared.behaviour == YOKED_COPY:
        copies = [c.id for c in spec.conditions if c.behaviour == COPY]
        params = {k: v for k, v in declared.params.items() if k != "clip"}
        if needs_seed(params) and params.get("seed") is None:
            params["seed"] = interaction_id
        # Another participant's copy interaction, else (the first participants) the clip.
        wanted = {"source": "yoked", "clip": declared.params.get("clip", DEFAULT_CLIP)}
        source = natural_source(db, state, located, wanted, copies)
        wire = (
            {"seed": source["seed"]}
            if source["source"] == "synthetic"
            else {"path": source["path"]}
        )
        return RobotBehaviour(YOKED_COPY, {**params, **wire}, source)
    if declared.behaviour != NATURAL:
        params = dict(declared.params)
        if declared.behaviour == COPY and needs_seed(params) and params.get("seed") is None:
            params["seed"] = interaction_id  # a different, recorded draw per interaction
        return RobotBehaviour(declared.behaviour, params)
    replaying = {c.id for c in spec.conditions if c.behaviour == NATURAL}
    yokeable = [c.id for c in spec.conditions if c.id not in replaying]
    source = natural_source(db, state, located, declared.params, yokeable)
    return RobotBehaviour(NATURAL, natural_wire_params(declared.params, source), source)


def behaviour_words(chosen: RobotBehaviour, booth_mirror: bool | None) -> str:
    """What the robot does in this interaction, in words, for the export and the console."""
    if chosen.name == COPY:
        return in_words(chosen.params, booth_mirror)
    if chosen.name == YOKED_COPY and chosen.natural_source is not None:
        shaped = {k: v for k, v in chosen.params.items() if k != "path"}
        replayed = describe_source(chosen.natural_source)
        return in_words(shaped, booth_mirror).replace("copies", f"replays {replayed}:", 1)
    if chosen.name == NATURAL and chosen.natural_source is not None:
        return "replays " + describe_source(chosen.natural_source)
    if chosen.name == "still":
        return "holds still (neutral face)"
    params = ", ".join(f"{k} {v}" for k, v in sorted(chosen.params.items()))
    return chosen.name + (f" ({params})" if params else "")


def natural_wire_params(params: dict[str, Any], source: dict[str, Any]) -> dict[str, Any]:
    """The worker's ``natural`` parameters for a chosen source."""
    wire: dict[str, Any] = {"offset": params.get("offset", 0.0), "loop": params.get("loop", True)}
    if source["source"] == "synthetic":
        wire["seed"] = source["seed"]
    else:
        wire["path"] = source["path"]
    return wire


def natural_source(
    db: Session,
    state: Any,
    located: repository.Located,
    params: dict[str, Any],
    yokeable: list[str],
) -> dict[str, Any]:
    """The recording ``natural`` replays in this interaction: chosen once, then the same
    (unless its file has gone), logged and written on the interaction."""
    chosen = repository.chosen_natural_source(db, located.interaction.id)
    if chosen is not None:
        path = chosen.payload.get("path")
        if not path or resolve_marked_path(str(path), state.settings).is_file():
            return dict(chosen.payload)
    source = _choose(db, state, located, params, yokeable)
    events.record(
        db, repository.NATURAL_SOURCE, source="server", study_id=located.session.study_id,
        session_id=located.session.id, interaction_id=located.interaction.id, payload=source,
    )  # fmt: skip
    located.interaction.natural_source = source["source"]
    located.interaction.natural_recording = describe_source(source)
    db.flush()
    return source


def describe_source(source: dict[str, Any]) -> str:
    """One line for the export and the console: which recording ``natural`` replayed."""
    kind = source["source"]
    if kind == "synthetic":
        return f"synthetic face, seed {source['seed']}"
    if kind == "yoked":
        return (
            f"participant {source['from_participant']}, interaction "
            f"{source['from_position']} ({source['from_condition']}), recording "
            f"{source['recording_id']}"
        )
    text = f"clip {source['clip']}"
    notes = [source["note"]] if source.get("note") else []
    if source.get("synthetic_demo"):
        notes.append("the synthetic demo clip, not a real conversation")
    return text + (f" ({'; '.join(notes)})" if notes else "")


def clip_file(state: Any, clip: str) -> Path:
    """A clip named in the study: ``NAME`` is ``_natural/NAME.npz`` in the prompts folder; a
    name with a ``/`` is a path inside the prompts folder (``.npz`` added when missing).
    Looked up in the prompts folder in use, else the repository's."""
    relative = Path(clip) if "/" in clip else NATURAL_CLIPS / clip
    if not relative.suffix:
        relative = relative.with_suffix(".npz")
    in_use = prompts_root(state.settings) / relative
    return in_use if in_use.is_file() else REPOSITORY_PROMPTS / relative


def _choose(
    db: Session,
    state: Any,
    located: repository.Located,
    params: dict[str, Any],
    yokeable: list[str],
) -> dict[str, Any]:
    kind = params.get("source", "clip")
    if kind == "synthetic":
        return {"source": "synthetic", "seed": int(params.get("seed", 0))}
    note = ""
    if kind == "yoked":
        yoked = _yoked(db, state, located, params, yokeable)
        if yoked is not None:
            return yoked
        note = "yoked: no recording of another participant yet"
    clip = str(params.get("clip", DEFAULT_CLIP))
    path = clip_file(state, clip)
    source: dict[str, Any] = {"source": "clip", "clip": clip,
                              "path": marked_path(path, state.settings)}  # fmt: skip
    if note:
        source["note"] = note
    if is_synthetic_demo(path):
        source["synthetic_demo"] = True
    return source


def is_synthetic_demo(path: Path) -> bool:
    """Whether ``path`` holds the shipped synthetic demo clip (by content, so a copy of it
    in a lab's own prompts folder, under any name, counts too)."""
    try:
        if not path.is_file() or path.stat().st_size != SYNTHETIC_DEMO_CLIP.stat().st_size:
            return False
        return _digest(path.resolve(), path.stat().st_mtime_ns) == _digest(
            SYNTHETIC_DEMO_CLIP.resolve(), SYNTHETIC_DEMO_CLIP.stat().st_mtime_ns
        )
    except OSError:
        return False


@functools.lru_cache(maxsize=32)
def _digest(path: Path, _mtime_ns: int) -> str:
    """A file's SHA-256 (cached per modification time: asked on every console load)."""
    return hashlib.sha256(path.read_bytes()).hexdigest()


def demo_clip_conditions(state: Any, spec: Study) -> list[str]:
    """The conditions whose ``natural`` replays the synthetic demo clip: its ``clip``
    source, or ``yoked`` until another participant has been recorded."""
    return [
        condition.id
        for condition in spec.conditions
        if condition.behaviour in (NATURAL, YOKED_COPY)  # yoked_copy: its clip at first
        and condition.params.get("source", "clip") in ("clip", "yoked")
        and is_synthetic_demo(clip_file(state, str(condition.params.get("clip", DEFAULT_CLIP))))
    ]


def demo_clip_warning(state: Any, spec: Study, conditions: list[str] | None = None) -> str:
    """The warning for real participants, or "" (only ``conditions`` when given)."""
    found = [c for c in demo_clip_conditions(state, spec) if conditions is None or c in conditions]
    if not found:
        return ""
    which = ", ".join(found)
    return (
        f"Condition {which} replays the synthetic demo clip {DEFAULT_CLIP} (the face "
        "simulator's, made for the demo), not a recording of a real conversation. Before "
        "real participants, record a natural clip (chameleons prompts import prompts/m1 TAKE "
        "--natural NAME) and name it in the study's natural condition (clip: m1/natural/NAME)."
    )


def _yoked(
    db: Session,
    state: Any,
    located: repository.Located,
    params: dict[str, Any],
    yokeable: list[str],
) -> dict[str, Any] | None:
    data_dir = data_dir_of(state)
    # A clip needs two frames at least, whatever the study allows.
    min_frames = max(2, math.ceil(float(params.get("yoked_min_seconds", 30.0)) * PHONE_FPS))
    for recording, code, position, condition in repository.yoked_candidates(
        db, located.interaction, located.session, min_frames, yokeable
    ):
        path = recording_file(data_dir, recording.path)
        if path.is_file():
            return {
                "source": "yoked", "path": marked_path(path, state.settings),
                "recording_id": recording.id, "from_interaction_id": recording.interaction_id,
                "from_participant": code, "from_position": position,
                "from_condition": condition, "frames": recording.frames,
            }  # fmt: skip
    return None
