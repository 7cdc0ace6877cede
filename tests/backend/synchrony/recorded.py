"""A study whose interactions have real face recordings, written by the worker's own
recorder (:class:`FrameRecorder`, Parquet, format 2) as a booth would: the participant's
face at 60 Hz, the robot's frames at 125 Hz by condition (copy: the participant's face 4 s
later; still: the neutral face; natural: a face of its own), the robot's speech in the
timeline with worker timestamps (its mouth then moves with lip-sync)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from sqlalchemy import select
from sqlalchemy.orm import Session as DbSession

from chameleons.backend.models import Event, Interaction, Recording, Session
from chameleons.experiment.stats.synchrony import FaceStream
from chameleons.worker.frames import BLENDSHAPE_INDEX, N_BLENDSHAPES, FaceFrame
from chameleons.worker.recording import FrameRecorder
from tests.experiment.synchrony_data import delayed, smooth_face
from tests.support.factories import PopulatedStudy, populate

SECONDS = 70.0
CLOCK = 5000.0  # the worker's monotonic clock when the interactions start
CHANNELS = ("head_yaw", "head_pitch", "head_roll", "browInnerUp", "eyeBlinkLeft",
            "mouthSmileLeft", "jawOpen")  # fmt: skip
SPEECH = ((10.0, 16.0), (40.0, 47.0))  # seconds into the interaction


def vector(stream: FaceStream, index: int) -> np.ndarray:
    """One frame as the worker's 61-value vector (52 blendshapes, head, eyes)."""
    out = np.zeros(N_BLENDSHAPES + 9, dtype=np.float32)
    for column, name in enumerate(stream.channels):
        value = stream.values[index, column]
        if name.startswith("head_"):
            out[N_BLENDSHAPES + ("head_yaw", "head_pitch", "head_roll").index(name)] = value
        else:
            out[BLENDSHAPE_INDEX[name]] = value
    return out


def write(path: Path, stream: FaceStream, source: str, offset: float) -> int:
    with FrameRecorder(path, chunk_frames=512, chunk_seconds=1e6) as recorder:
        for index, when in enumerate(stream.times):
            recorder.write(FaceFrame.from_vector(vector(stream, index), offset + when,
                                                 offset + when + 0.01, source))  # fmt: skip
    return len(stream.times)


def robot_for(condition: str, participant: FaceStream, seed: int) -> FaceStream:
    if condition == "copy":
        return delayed(participant, 4.0, noise=0.01, seed=seed)
    if condition == "natural":
        return delayed(smooth_face(seed + 5000, SECONDS + 4, channels=CHANNELS), 0.0)
    times = np.arange(participant.start, participant.end, 1 / 125)  # still: neutral
    values = np.zeros((len(times), len(CHANNELS)))
    jaw = CHANNELS.index("jawOpen")
    for start, end in SPEECH:  # lip-sync moves the still robot's jaw while it speaks
        speaking = (times >= start) & (times <= end)
        values[speaking, jaw] = 0.5 + 0.4 * np.sin(times[speaking] * 17.0)
    return FaceStream.of(times, values, CHANNELS)


def recorded_study(db: DbSession, data_dir: Path, participants: int = 4,
                   rehearsals: int = 0) -> PopulatedStudy:  # fmt: skip
    """A populated study (:func:`populate`) whose interactions have real recordings."""
    study = populate(db, participants, rehearsals=rehearsals)
    interactions = db.scalars(
        select(Interaction).join(Session, Session.id == Interaction.session_id)
        .where(Session.study_id == study.study_id).order_by(Interaction.id)
    )  # fmt: skip
    for interaction in interactions:
        record_interaction(db, data_dir, interaction)
    db.flush()
    return study


def record_interaction(db: DbSession, data_dir: Path, interaction: Interaction) -> None:
    folder = data_dir / "recordings" / f"session-{interaction.session_id}"
    participant = smooth_face(interaction.id, SECONDS, channels=CHANNELS)
    robot = robot_for(interaction.condition, participant, interaction.id)
    offset = CLOCK + 1000.0 * interaction.id
    for stream, frames, source in (("participant", participant, "livelink"),
                                   ("agent", robot, "agent")):  # fmt: skip
        path = folder / f"interaction-{interaction.id}-{stream}.parquet"
        count = write(path, frames, source, offset)
        db.add(Recording(interaction_id=interaction.id, stream=stream,
                         path=str(path.relative_to(data_dir)), frames=count,
                         size_bytes=path.stat().st_size))  # fmt: skip
    session = db.get(Session, interaction.session_id)
    assert session is not None
    for start, end in SPEECH:
        for kind, when in (("prompt.speech_start", start), ("prompt.speech_end", end)):
            db.add(Event(study_id=session.study_id, session_id=session.id,
                         interaction_id=interaction.id, kind=kind, source="worker",
                         worker_time=offset + when, payload={}))  # fmt: skip
