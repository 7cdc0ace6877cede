"""Errors of the study/session flow, each with the HTTP status it maps to.

Messages are whole sentences meant for people: the wizard console and the phone show them.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager

from fastapi import HTTPException, status


class FlowError(Exception):
    """``message`` may have ``{name}`` placeholders filled from ``params``: the phone shows
    the sentence translated (``template`` is the message id of its catalogue)."""

    status_code = status.HTTP_400_BAD_REQUEST

    def __init__(self, message: str, **params: object) -> None:
        self.template = message
        self.params = params
        self.message = message.format(**params) if params else message
        super().__init__(self.message)


class NotFoundError(FlowError):
    status_code = status.HTTP_404_NOT_FOUND


class ConflictError(FlowError):
    """The request is well-formed but not allowed in the current state (HTTP 409)."""

    status_code = status.HTTP_409_CONFLICT


class ConfirmationNeededError(ConflictError):
    """Allowed only when confirmed (HTTP 409): the detail is ``{"message", "confirm"}``, and
    repeating the request with ``confirm`` set to true goes ahead."""

    def __init__(self, message: str, confirm: str) -> None:
        super().__init__(message)
        self.confirm = confirm


class InvalidInputError(FlowError):
    """The request's content is wrong (HTTP 422); nothing was changed."""

    status_code = status.HTTP_422_UNPROCESSABLE_CONTENT


class GoneError(FlowError):
    """The session is over; its phone link no longer works (HTTP 410)."""

    status_code = status.HTTP_410_GONE


@contextmanager
def http_errors() -> Iterator[None]:
    """Turn flow errors into HTTP errors (the write transaction then rolls back)."""
    try:
        yield
    except ConfirmationNeededError as exc:
        detail = {"message": exc.message, "confirm": exc.confirm}
        raise HTTPException(exc.status_code, detail) from exc
    except FlowError as exc:
        raise HTTPException(exc.status_code, exc.message) from exc
