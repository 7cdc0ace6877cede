"""Which capture source recorded the participant: read from the recording file itself.

Every frame of a format-2 recording names its source (``livelink``, ``facecapturex``,
``webcam-browser``, ``webcam-python``) and a webcam's calibration (``geometric``: the
defaults, not calibrated; ``neutral``: the participant's neutral face; ``iphone:<hash>``:
the lab's iPhone-taught map; ``neutral+iphone:<hash>``). The source of most frames is the
recording's, and the interaction's (:func:`note_face_source`).
"""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path

import pyarrow as pa
from sqlalchemy.orm import Session

from chameleons.backend.models import Interaction, Recording
from chameleons.worker.recording import RecordingError, recorded_sources


def dominant_source(path: Path) -> tuple[str | None, str | None]:
    """(source, calibration) of most of the file's frames; (None, None) when it does not
    say (a format-1 file, an unreadable one, no frames)."""
    try:
        counts = recorded_sources(path)
    except (OSError, pa.ArrowException, RecordingError, ValueError):
        return None, None
    named = {key: n for key, n in counts.items() if key[0]}
    if not named:
        return None, None
    source, calibration = max(named, key=lambda key: named[key])
    return source[:32], (calibration[:64] or None)


def note_face_source(db: Session, interaction_id: int, rows: Iterable[Recording]) -> None:
    """The interaction's face source: its participant recording's with the most frames."""
    known = [r for r in rows if r.stream == "participant" and r.face_source]
    if not known:
        return
    best = max(known, key=lambda r: r.frames)
    interaction = db.get(Interaction, interaction_id)
    if interaction is not None:
        interaction.face_source = best.face_source
        interaction.face_calibration = best.face_calibration
