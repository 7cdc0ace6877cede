"""The API documentation page (/docs) under its own Content-Security-Policy.

FastAPI's Swagger UI page loads its script and style from a CDN and starts with an inline
script. Rather than loosen the policy of every page, this one page gets a policy of its own:
its scripts run only with a nonce made for each response, and only the CDN is added to the
sources. ReDoc (a second copy of the same information) is switched off in the app factory.
"""

from __future__ import annotations

import secrets

from fastapi import APIRouter, Request
from fastapi.openapi.docs import get_swagger_ui_html
from fastapi.responses import HTMLResponse

router = APIRouter()

SWAGGER_CDN = "https://cdn.jsdelivr.net"
SWAGGER_FAVICON = "https://fastapi.tiangolo.com"


def docs_policy(nonce: str) -> str:
    return "; ".join(
        (
            "default-src 'self'",
            f"script-src 'nonce-{nonce}'",
            f"style-src 'self' {SWAGGER_CDN}",
            f"img-src 'self' data: {SWAGGER_CDN} {SWAGGER_FAVICON}",
            "connect-src 'self'",
            "object-src 'none'",
            "base-uri 'none'",
            "form-action 'self'",
            "frame-ancestors 'none'",
        )
    )


@router.get("/docs", include_in_schema=False)
def api_docs(request: Request) -> HTMLResponse:
    nonce = secrets.token_urlsafe(16)
    page = get_swagger_ui_html(openapi_url=request.app.openapi_url, title="Chameleons API")
    html = bytes(page.body).decode().replace("<script", f'<script nonce="{nonce}"')
    return HTMLResponse(html, headers={"Content-Security-Policy": docs_policy(nonce)})
