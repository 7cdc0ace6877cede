"""Security headers on every HTTP response (pages, API, static files, errors), and
``Cache-Control: no-store`` on every one but static assets and prompt audio.

A pure ASGI middleware rather than ``BaseHTTPMiddleware``: it only adds headers at
``http.response.start``, so streaming responses (exports, recordings) stay streaming and
WebSockets pass through untouched.

The Content-Security-Policy allows scripts, styles, fonts and connections from this origin
only: the templates carry no inline script, no inline event handler and no ``style``
attribute (data for a page travels in ``data-*`` attributes or a
``<script type="application/json">`` block, which is never executed). Chromium's CSP level 3
lets ``'self'`` match ``ws:``/``wss:`` to the same host, so ``connect-src 'self'`` covers
the WebSockets. Images may be ``data:``/``blob:`` URLs (QR codes, plots drawn in the page);
media may be ``blob:`` or ``data:`` (the display page probes autoplay with a tiny silent
``data:`` WAV; media cannot run code).

A route may set its own policy (the API documentation page loads Swagger UI from its CDN
with a per-response nonce): the middleware then leaves that one header alone.
"""

from __future__ import annotations

from starlette.datastructures import MutableHeaders
from starlette.types import ASGIApp, Message, Receive, Scope, Send

CONTENT_SECURITY_POLICY = "; ".join(
    (
        "default-src 'self'",
        "script-src 'self'",
        "style-src 'self'",
        "img-src 'self' data: blob:",
        "media-src 'self' blob: data:",
        "font-src 'self'",
        "connect-src 'self'",
        "object-src 'none'",
        "base-uri 'none'",
        "form-action 'self'",
        "frame-ancestors 'none'",
    )
)

SECURITY_HEADERS = {
    "Content-Security-Policy": CONTENT_SECURITY_POLICY,
    "X-Frame-Options": "DENY",
    "X-Content-Type-Options": "nosniff",
    # Participant and display links carry their credential in the path: same-origin keeps
    # them out of other sites' logs (participant and display pages send no referrer at all).
    "Referrer-Policy": "same-origin",
    "Cross-Origin-Opener-Policy": "same-origin",
}


# What a browser (or a proxy) may keep: the static assets and the prompts' recorded audio.
# Every other response (staff pages and API, exports, participant pages, redirects, errors)
# is personal or live and gets "Cache-Control: no-store" unless its route set its own: a
# staff page is then not kept on disk nor shown again from the back/forward cache after
# logging out on a shared lab PC.
CACHEABLE_PREFIXES = ("/static/", "/media/prompts/", "/favicon.ico")
NO_STORE = "no-store"


class SecurityHeadersMiddleware:
    def __init__(self, app: ASGIApp) -> None:
        self.app = app

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return

        cacheable = str(scope.get("path", "")).startswith(CACHEABLE_PREFIXES)

        async def send_with_headers(message: Message) -> None:
            if message["type"] == "http.response.start":
                headers = MutableHeaders(scope=message)
                for name, value in SECURITY_HEADERS.items():
                    if name not in headers:  # a route's own (stricter or specific) value wins
                        headers[name] = value
                if not cacheable and "cache-control" not in headers:
                    headers["Cache-Control"] = NO_STORE
            await send(message)

        await self.app(scope, receive, send_with_headers)
