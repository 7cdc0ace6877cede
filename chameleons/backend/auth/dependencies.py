"""Who is asking: staff login (session cookie) and role checks."""

from __future__ import annotations

from typing import Annotated
from urllib.parse import quote

from fastapi import Depends, HTTPException, Request, status

from chameleons.backend.auth import sessions
from chameleons.backend.dependencies import DbSession
from chameleons.backend.models import StaffUser


class LoginRequiredError(Exception):
    """Raised for a staff page without login; the app turns it into a redirect to /login."""

    def __init__(self, next_path: str) -> None:
        super().__init__(next_path)
        self.next_path = next_path


def _is_api(request: Request) -> bool:
    return request.url.path.startswith("/api/") or request.url.path.startswith("/ws/")


def current_staff(request: Request, db: DbSession) -> StaffUser:
    """The signed-in staff member, read in a session of its own that gives its connection
    back at once, and handed to the request's session without a statement.

    Read with the request's session, the connection stayed checked out from this dependency
    (one thread-pool call) until the endpoint (another) committed: requests waiting for a
    thread held connections while every thread waited for a connection, until the pool's
    30 s timeout (bench/server_hold.py, 200 phones on SQLite: every phone failed)."""
    with request.app.state.read_sessionmaker() as own:
        user = sessions.staff_of(own, request.session)
    if user is None:
        if _is_api(request):
            raise HTTPException(status.HTTP_401_UNAUTHORIZED, "Log in as staff first.")
        target = request.url.path + (f"?{request.url.query}" if request.url.query else "")
        raise LoginRequiredError(quote(target, safe="/?=&"))
    return db.merge(user, load=False)


class PIRequiredError(Exception):
    """A wizard opened a PI page; the app answers with a readable 403 page."""


def require_pi(request: Request, user: Annotated[StaffUser, Depends(current_staff)]) -> StaffUser:
    if user.role != "pi":
        if _is_api(request):
            raise HTTPException(status.HTTP_403_FORBIDDEN, "Only the PI can do this.")
        raise PIRequiredError
    return user


CurrentStaff = Annotated[StaffUser, Depends(current_staff)]
CurrentPI = Annotated[StaffUser, Depends(require_pi)]
