"""The one error type of the ingest parsers."""

from __future__ import annotations


class IngestError(ValueError):
    """Input that cannot become a face frame. ``reason`` is a short drop-counter key
    (``truncated``, ``wrong_version``, ``bad_length``, ``non_finite``, ``oversized``, ...)."""

    def __init__(self, reason: str, detail: str = "") -> None:
        super().__init__(f"{reason}: {detail}" if detail else reason)
        self.reason = reason
        self.detail = detail
