"""``/capture/<booth>/<key>``: the booth's webcam capture page (no login; the key is the
credential and a wrong, rotated or retired one is a 404, as for the robot display)."""

from __future__ import annotations

from fastapi import HTTPException, Request, status
from fastapi.responses import HTMLResponse, Response

from chameleons.backend.auth.dependencies import CurrentStaff
from chameleons.backend.capture import links
from chameleons.backend.dependencies import DbSession, Templates
from chameleons.backend.display.tokens import is_valid_booth
from chameleons.backend.routing import make_router
from chameleons.backend.security_headers import CONTENT_SECURITY_POLICY
from chameleons.backend.sessions.endpoints import qr_svg
from chameleons.facemesh.assets import VERSION

router = make_router(tags=["capture"])

# MediaPipe's wasm is compiled in the page ('wasm-unsafe-eval'); its Emscripten glue builds
# a few named functions with the Function constructor ('unsafe-eval'). Both for this page
# only, which loads nothing but this site's own scripts.
CAPTURE_CSP = CONTENT_SECURITY_POLICY.replace(
    "script-src 'self'", "script-src 'self' 'wasm-unsafe-eval' 'unsafe-eval'"
)


@router.get("/capture/{booth}/{token}", response_class=HTMLResponse)
def capture_page(
    request: Request, booth: str, token: str, templates: Templates, db: DbSession
) -> Response:
    """The webcam capture page of one booth."""
    if not is_valid_booth(booth) or not links.token_works(db, request.app, booth, token):
        raise HTTPException(status.HTTP_404_NOT_FOUND, "No such capture page.")
    vendor = str(request.url_for("static", path="/vendor/mediapipe-face-mesh/").path)
    context = {"booth": booth, "ws_path": f"/ws/capture/{booth}?token={token}",
               "vendor": vendor, "version": VERSION,
               "video_path": f"/video/{booth}/{token}"}  # fmt: skip
    response = templates.TemplateResponse(request, "capture/page.html", context)
    response.headers["Referrer-Policy"] = "no-referrer"
    response.headers["Cache-Control"] = "no-store"
    response.headers["Content-Security-Policy"] = CAPTURE_CSP
    response.headers["Permissions-Policy"] = "camera=(self)"
    return response


@router.get("/api/capture/{booth}/qr.svg")
def capture_qr(request: Request, booth: str, _user: CurrentStaff) -> Response:
    """Staff: the booth's capture link as a QR code (to open it on a laptop or tablet)."""
    valid = is_valid_booth(booth)
    url = links.capture_url(request.app, booth, links.request_base(request)) if valid else None
    if url is None:
        raise HTTPException(status.HTTP_404_NOT_FOUND, "No capture link for that booth.")
    return Response(qr_svg(url, "Webcam capture link"), media_type="image/svg+xml",
                    headers={"Cache-Control": "no-store"})  # fmt: skip
