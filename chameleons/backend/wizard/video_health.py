"""The console's *Participant video* chip: whether the booth's recording page
(``/video/<booth>/<key>``, docs/instruments.md "Participant video") films a session whose
study records video and whose participant agreed.

Green while chunks come (the page uploads one every 2 s), amber once a running session has
had none for :data:`SILENT_AFTER_S` (the page is closed, has no camera, or was never
opened), grey when nobody is to be filmed now; no chip for a study that films nobody.
Health is sent only when it changes: the value says the coarse state and the chunk count,
and the seconds since the last chunk go apart (``since_s``), which the console counts on
from the message's arrival, as it does a failing check's time.
"""

from __future__ import annotations

from datetime import datetime

from chameleons.backend.video.repository import Filming
from chameleons.backend.wizard.health import Check

SILENT_AFTER_S = 6.0  # three missed 2 s chunks
CHIP = "video"
NOT_OPEN = "video consented but the booth's recording page is not open/recording"


def video_check(filming: Filming | None, now: datetime) -> dict[str, Check]:
    """The chip for the session's filming at ``now`` (None: no session, no chip)."""
    if filming is None:
        return {}
    if not filming.consent:
        value = ("waiting for the participant's consent" if filming.state == "pending"
                 and filming.consent is None else "not filmed: no consent")  # fmt: skip
        return {CHIP: Check(CHIP, None, value)}
    since = None if filming.last_chunk_at is None else max(
        0.0, (now - filming.last_chunk_at).total_seconds())  # fmt: skip
    if filming.state != "running":
        if filming.state == "pending":
            return {CHIP: Check(CHIP, None, "consented: filmed once the session runs")}
        return {CHIP: Check(CHIP, None, f"not filming now: {_chunks(filming.chunks)} recorded")}
    if since is not None and since < SILENT_AFTER_S:
        return {CHIP: Check(CHIP, True, f"recording: {_chunks(filming.chunks)}",
                            since_s=since)}  # fmt: skip
    started = filming.started_at
    if since is None and started is not None and (now - started).total_seconds() < SILENT_AFTER_S:
        return {CHIP: Check(CHIP, None, "starting: waiting for the recording page's first chunk")}
    if since is None:
        return {CHIP: Check(CHIP, False, f"{NOT_OPEN}: no chunk yet")}
    return {CHIP: Check(CHIP, False, f"{NOT_OPEN}: {_chunks(filming.chunks)}", since_s=since)}


def _chunks(count: int) -> str:
    return "1 chunk" if count == 1 else f"{count} chunks"
