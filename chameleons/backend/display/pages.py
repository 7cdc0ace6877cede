"""The robot display page (booth screen) and the staff page that lists its links."""

from __future__ import annotations

from typing import Annotated

from fastapi import Depends, Form, HTTPException, Query, Request, status
from fastapi.responses import FileResponse, HTMLResponse, RedirectResponse, Response
from sqlalchemy import select

from chameleons.backend.auth.csrf import verify_csrf
from chameleons.backend.auth.dependencies import CurrentPI, CurrentStaff
from chameleons.backend.dependencies import AppSettings, DbSession, Templates
from chameleons.backend.display import links, renderers
from chameleons.backend.display.channel import get_display_channel
from chameleons.backend.display.protocol import FACE_IDS
from chameleons.backend.display.tokens import (
    BOOTH_PATTERN,
    capture_path,
    display_path,
    is_valid_booth,
    signing_key,
)
from chameleons.backend.models import Session
from chameleons.backend.routing import make_router
from chameleons.backend.security_headers import CONTENT_SECURITY_POLICY
from chameleons.settings import Settings

router = make_router(tags=["display"])

DEFAULT_BOOTH = "booth-1"


def _render(
    request: Request, templates: Templates, db: DbSession, booth: str, token: str | None
) -> Response:
    settings: Settings = request.app.state.settings
    query = f"?token={token}" if token else ""
    booth_renderer, booth_head = links.defaults(db, booth)
    renderer, source = renderers.choose(request.query_params.get("renderer"), booth_renderer,
                                        settings)  # fmt: skip
    head = request.query_params.get("head") or booth_head
    head_url = None
    if head and renderers.head_file(settings, head) is not None:
        head_url = str(request.url_for("display_head", name=head).path)
    import_map, map_source = renderers.import_map(str(request.url_for("static", path="/").path))
    context = {
        "booth": booth,
        "ws_path": f"/ws/display/{booth}{query}",
        "faces": FACE_IDS,
        "initial_face": FACE_IDS[0],
        "renderer": renderer,
        "renderer_source": source,
        "head_url": head_url,
        "import_map": import_map,
    }
    response = templates.TemplateResponse(request, "display/robot.html", context)
    # The link is the credential: keep it out of other sites' logs and out of caches.
    response.headers["Referrer-Policy"] = "no-referrer"
    response.headers["Cache-Control"] = "no-store"
    # The import map is the page's only inline script: allowed by its hash. A lab's GLB
    # head may embed textures, which three.js decodes through blob: URLs.
    response.headers["Content-Security-Policy"] = CONTENT_SECURITY_POLICY.replace(
        "script-src 'self'", f"script-src 'self' {map_source}"
    ).replace("connect-src 'self'", "connect-src 'self' blob:")
    return response


@router.get("/display", response_class=HTMLResponse)
def display_links(
    request: Request,
    user: CurrentStaff,
    db: DbSession,
    settings: AppSettings,
    templates: Templates,
    booth: Annotated[str | None, Query(max_length=64)] = None,
) -> Response:
    """Staff: the unguessable display link of every known booth (and of one typed in)."""
    booths = {DEFAULT_BOOTH, *db.scalars(select(Session.booth).distinct())}
    error = None
    if booth:
        if is_valid_booth(booth):
            booths.add(booth)
        else:
            error = "A booth id uses letters, digits, '-', '_' and '.' (at most 64)."
    key = signing_key(request.app)
    base = settings.effective_public_url
    booths |= links.retired_booths(db)
    rows = []
    for b in sorted(booths):
        current = links.generation(db, b)
        renderer, head = links.defaults(db, b)
        url = None if current is None else base + display_path(key, b, current)
        capture = None if current is None else base + capture_path(key, b, current)
        rows.append((b, url, renderer or "", head or "", capture))
    context = {
        "user": user,
        "links": rows,
        "default_renderer": settings.display_renderer,
        "heads": renderers.available_heads(settings),
        "heads_dir": str(renderers.heads_dir(settings)),
        "error": error,
        "booth_pattern": BOOTH_PATTERN[1:-1],
        "is_pi": user.role == "pi",
    }
    return templates.TemplateResponse(request, "display/links.html", context)


@router.post("/display/{booth}/rotate", dependencies=[Depends(verify_csrf)])
def rotate_link(request: Request, booth: str, _user: CurrentPI, db: DbSession) -> Response:
    """PI: a new link for the booth; pages open with the old one are disconnected."""
    _valid_or_404(booth)
    links.rotate(db, booth)
    get_display_channel(request.app).revoke(booth, "display link rotated by the PI")
    return RedirectResponse("/display", status_code=status.HTTP_303_SEE_OTHER)


@router.post("/display/{booth}/retire", dependencies=[Depends(verify_csrf)])
def retire_link(request: Request, booth: str, _user: CurrentPI, db: DbSession) -> Response:
    """PI: the booth is out of use; its link stops working (a rotation issues a new one)."""
    _valid_or_404(booth)
    links.retire(db, booth)
    get_display_channel(request.app).revoke(booth, "booth retired by the PI")
    return RedirectResponse("/display", status_code=status.HTTP_303_SEE_OTHER)


@router.post("/display/{booth}/defaults", dependencies=[Depends(verify_csrf)])
def set_defaults(
    request: Request,
    booth: str,
    _user: CurrentPI,
    db: DbSession,
    settings: AppSettings,
    renderer: Annotated[str, Form(max_length=8)] = "",
    head: Annotated[str, Form(max_length=128)] = "",
) -> Response:
    """PI: the booth display's own default face (2D/3D, a lab's head); open pages pick it
    up when they reload."""
    _valid_or_404(booth)
    if renderer not in ("", *renderers.RENDERERS):
        raise HTTPException(status.HTTP_422_UNPROCESSABLE_CONTENT, "The face is 2D or 3D.")
    if head and renderers.head_file(settings, head) is None:
        raise HTTPException(
            status.HTTP_422_UNPROCESSABLE_CONTENT,
            f"No head file {head!r} in {renderers.heads_dir(settings)}.",
        )
    links.set_defaults(db, booth, renderer or None, head or None)
    return RedirectResponse("/display", status_code=status.HTTP_303_SEE_OTHER)


@router.get("/display-heads/{name}", name="display_head")
def display_head(name: str, settings: AppSettings) -> Response:
    """A lab's own head file (GLB/VRM) for the display pages; these are not secret."""
    path = renderers.head_file(settings, name)
    if path is None:
        raise HTTPException(status.HTTP_404_NOT_FOUND, "No such head.")
    return FileResponse(path, media_type="model/gltf-binary")


def _valid_or_404(booth: str) -> None:
    if not is_valid_booth(booth):
        raise HTTPException(status.HTTP_404_NOT_FOUND, "No such booth.")


@router.get("/display/{booth}", response_class=HTMLResponse)
def staff_display(
    request: Request, booth: str, _user: CurrentStaff, templates: Templates, db: DbSession
) -> Response:
    """The display for a logged-in staff member (no token in the link)."""
    if not is_valid_booth(booth):
        raise HTTPException(status.HTTP_404_NOT_FOUND, "No such booth.")
    return _render(request, templates, db, booth, None)


@router.get("/display/{booth}/{token}", response_class=HTMLResponse)
def booth_display(
    request: Request, booth: str, token: str, templates: Templates, db: DbSession
) -> Response:
    """The booth screen's own link: works without a login, 404 for a wrong, rotated or
    retired one."""
    if not is_valid_booth(booth) or not links.token_works(db, request.app, booth, token):
        raise HTTPException(status.HTTP_404_NOT_FOUND, "No such display.")
    return _render(request, templates, db, booth, token)
