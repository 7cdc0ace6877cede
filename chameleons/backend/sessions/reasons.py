"""A reason the wizard gives (ending a session early, pausing it): one of a fixed list,
with a note that "other" needs."""

from __future__ import annotations

from chameleons.backend.studies.errors import InvalidInputError

MAX_NOTE = 1000


def check_reason(reasons: dict[str, str], reason: str, note: str, act: str, why: str) -> str:
    """The note, stripped, when ``reason`` is one of ``reasons`` and "other" says why; the
    refusals name what the wizard was doing (``act``: "end a session", ``why``: "the
    session ends")."""
    if reason not in reasons:
        raise InvalidInputError(
            f"{reason!r} is not a reason to {act}; use one of {', '.join(reasons)}."
        )
    note = note.strip()
    if reason == "other" and not note:
        raise InvalidInputError(f"Say in a few words why {why} (reason: other).")
    if len(note) > MAX_NOTE:
        raise InvalidInputError(f"The note is longer than {MAX_NOTE} characters.")
    return note
