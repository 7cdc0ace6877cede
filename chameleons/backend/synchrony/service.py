"""An interaction's synchrony from its recordings, stored (flushes only; the caller
commits). The measure itself is :mod:`chameleons.experiment.stats.synchrony`.

What it reads: the interaction's participant and robot recordings (all parts), the robot's
speech times from the timeline (``prompt.speech_start``/``_end`` with the worker's
timestamps: its mouth and jaw are lip-sync then, not behaviour), the condition's behaviour
and delay from the study's configuration (a ``copy`` interaction is checked against its
delay), and, for the pseudo-synchrony baseline, the recordings of other participants'
interactions of the same study (rehearsals with rehearsals), drawn in an order seeded by
the interaction's id, so recomputing gives the same pairs while the data are unchanged.
"""

from __future__ import annotations

import logging
import math
import random
from dataclasses import replace as with_changes
from pathlib import Path
from typing import Any

import pyarrow as pa
from sqlalchemy.orm import Session as DbSession

from chameleons.backend.models import InteractionSynchrony, Recording
from chameleons.backend.synchrony import repository
from chameleons.backend.synchrony.loading import CHANNELS, LoadedStream, load_stream
from chameleons.backend.withdrawal.files import recording_file
from chameleons.experiment.stats.synchrony import (
    FaceStream,
    SynchronyResult,
    SyncParams,
    mask_speech,
    measure_synchrony,
)
from chameleons.experiment.study import study_from_config
from chameleons.worker.behaviours.copy_params import nominal_delay
from chameleons.worker.recording import RecordingError

log = logging.getLogger(__name__)
STREAMS = ("participant", "agent")
REASONS = {
    "no_recording": "no recording",
    "unreadable": "recording unreadable",
    "no_frames": "no frames",
    "too_short": "too short",
    "robot_still": "robot did not move",
    "participant_still": "participant did not move",
    "no_common_channels": "no common channels",
    "gaps": "capture gaps",
}


def params_from(settings: Any) -> SyncParams:
    """The parameters a server's settings give (``sync_*``)."""
    return SyncParams(
        window_s=settings.sync_window_s,
        increment_s=settings.sync_increment_s,
        max_lag_s=settings.sync_max_lag_s,
        segment_s=settings.sync_window_s,
        surrogates=settings.sync_surrogates,
        min_between=min(SyncParams.min_between, settings.sync_surrogates),
    )


def compute(
    db: DbSession, interaction_id: int, data_dir: Path, base: SyncParams | None = None
) -> InteractionSynchrony | None:
    """Compute and store the interaction's synchrony; None when there is no interaction."""
    found = repository.context(db, interaction_id)
    if found is None:
        return None
    spec = study_from_config(found.study.config)
    condition = spec.condition(found.interaction.condition)
    delay = nominal_delay(condition.params) if condition.behaviour == "copy" else None
    params = _params_for(base or SyncParams(), delay, interaction_id)
    own = repository.recordings(db, [interaction_id]).get(interaction_id, {})
    row = InteractionSynchrony(interaction_id=interaction_id, params=params.to_dict())
    missing = [s for s in STREAMS if not own.get(s)]
    if missing:
        who = " and ".join("the participant" if s == "participant" else "the robot"
                           for s in missing)  # fmt: skip
        return _store(db, row, "no_recording", f"No face recording of {who}.")
    try:
        participant = _stream(data_dir, own["participant"])
        robot = _stream(data_dir, own["agent"])
    except (RecordingError, OSError, pa.ArrowException) as exc:
        return _store(db, row, "unreadable", f"A recording could not be read: {exc}")
    row.face_source = participant.source
    row.recordings = [r.id for s in STREAMS for r in own[s]]
    p_stream = _face(participant)
    r_stream = mask_speech(_face(robot), repository.speech(db, interaction_id), params)
    pairs: list[tuple[FaceStream, FaceStream]] = []
    offered: list[list[list[int]]] = []
    if _overlap(p_stream, r_stream) >= params.minimum_s:  # else nothing to compare with
        pairs, offered = _pseudo_pairs(db, found, data_dir, (p_stream, r_stream), own, params)
    result = measure_synchrony(p_stream, r_stream, pairs, params, delay)
    return _store_result(db, row, result, offered)


def _params_for(base: SyncParams, delay: float | None, interaction_id: int) -> SyncParams:
    """The lag range covers a copy's delay with 2 s to spare; the seed is the
    interaction's, so its pseudo-pairs are drawn the same way every time."""
    lag = base.max_lag_s
    if delay is not None and delay + 2.0 > lag:
        lag = float(math.ceil(delay + 2.0))
    return with_changes(base, max_lag_s=lag, seed=interaction_id)


def _stream(data_dir: Path, recordings: list[Recording]) -> LoadedStream:
    return load_stream([recording_file(data_dir, r.path) for r in recordings])


def _face(loaded: LoadedStream) -> FaceStream:
    return FaceStream.of(loaded.times, loaded.values, CHANNELS)


def _overlap(a: FaceStream, b: FaceStream) -> float:
    if a.empty or b.empty:
        return 0.0
    return min(a.end, b.end) - max(a.start, b.start)


def _pseudo_pairs(
    db: DbSession, found: repository.Context, data_dir: Path,
    dyad: tuple[FaceStream, FaceStream], own: dict[str, list[Recording]], params: SyncParams,
) -> tuple[list[tuple[FaceStream, FaceStream]], list[list[list[int]]]]:  # fmt: skip
    """This participant with other participants' robots, and other participants with this
    robot, alternately, from partners in a seeded order, up to ``params.surrogates``."""
    candidates = repository.partners(db, found)
    random.Random(params.seed).shuffle(candidates)
    participant, robot = dyad
    pairs: list[tuple[FaceStream, FaceStream]] = []
    offered: list[list[list[int]]] = []
    own_p, own_r = [r.id for r in own["participant"]], [r.id for r in own["agent"]]
    for partner in candidates:
        if len(pairs) >= params.surrogates:
            break
        streams = repository.recordings(db, [partner]).get(partner, {})
        try:
            other_p = _face(_stream(data_dir, streams["participant"]))
            other_r = mask_speech(_face(_stream(data_dir, streams["agent"])),
                                  repository.speech(db, partner), params)  # fmt: skip
        except (KeyError, RecordingError, OSError, pa.ArrowException) as exc:
            log.warning("synchrony: partner interaction %s skipped: %s", partner, exc)
            continue
        p_ids = [r.id for r in streams["participant"]]
        r_ids = [r.id for r in streams["agent"]]
        pairs += [(participant, other_r), (other_p, robot)]
        offered += [[own_p, r_ids], [p_ids, own_r]]
    return pairs[: params.surrogates], offered[: params.surrogates]


def _store_result(
    db: DbSession,
    row: InteractionSynchrony,
    result: SynchronyResult,
    offered: list[list[list[int]]],
) -> InteractionSynchrony:
    for name in ("sync_lag_s", "sync_r", "sync_band_r", "sync_p", "mimicry_lag_s", "mimicry_r",
                 "mimicry_raw_r", "mimicry_surrogate_r", "mimicry_p", "check", "surrogate_kind",
                 "surrogate_count"):  # fmt: skip
        setattr(row, name, getattr(result, name))
    row.check_reason = result.check_reason
    row.usable_share = result.usable_share
    row.channels = list(result.channels)
    row.surrogates = [offered[i] for i in result.surrogates_used if i < len(offered)]
    row.curves = {
        "lags_s": result.lags_s, "curve": result.curve, "head": result.head_curve,
        "face": result.face_curve, "surrogate_mean": result.surrogate_mean,
        "surrogate_high": result.surrogate_high, "windows": result.windows,
        "duration_s": result.duration_s, "mimicry_es": result.mimicry_es,
        "segment_s": result.segment_s,
    }  # fmt: skip
    return _store(db, row, result.reason, result.detail)


def _store(db: DbSession, row: InteractionSynchrony, reason: str | None,
           detail: str) -> InteractionSynchrony:  # fmt: skip
    row.reason, row.detail = reason, detail[:512]
    row.check_reason = (row.check_reason or "")[:512]
    return repository.replace(db, row)
