"""``chameleons serve`` answers a browser's offer of WebSocket compression (permessage-deflate,
RFC 7692) only when CHAMELEONS_WS_COMPRESSION says so: off by default, since compressing the
console's updates cost the server more than sending them on a lab's network
(docs/performance.md, "Fewer statements, no compression"). A real server process and a
client that offers the extension, as Chromium does."""

from __future__ import annotations

import secrets
from pathlib import Path

import pytest
from sqlalchemy import select
from websockets.sync.client import connect

from chameleons.backend.db import build_engine, build_sessionmaker, session_scope
from chameleons.backend.migrate import upgrade
from chameleons.backend.models import Session as SessionRow
from tests.reliability.test_live_fanout import serve_process, wait_until
from tests.support.factories import populate


def _phone_token(url: str) -> str:
    upgrade(url)
    engine = build_engine(url)
    try:
        with session_scope(build_sessionmaker(engine)) as db:
            populate(db, 1, seed=1)
            token = db.scalars(select(SessionRow.phone_token)).first()
        assert token is not None
        return token
    finally:
        engine.dispose()


@pytest.mark.parametrize(("setting", "compressed"), [(None, False), ("true", True)])
def test_serve_compresses_websockets_only_when_configured(
    tmp_path: Path, setting: str | None, compressed: bool
) -> None:
    url = f"sqlite:///{tmp_path / 'serve.sqlite3'}"
    token = _phone_token(url)
    extra = {} if setting is None else {"CHAMELEONS_WS_COMPRESSION": setting}
    with serve_process(url, secrets.token_urlsafe(32), tmp_path / "data", extra) as server:
        wait_until(server.ready, "chameleons serve answers")
        with connect(f"ws://127.0.0.1:{server.port}/ws/p/{token}", compression="deflate") as ws:
            assert ws.response is not None
            agreed = ws.response.headers.get("Sec-WebSocket-Extensions") or ""
            first = ws.recv(timeout=30)
    assert ("permessage-deflate" in agreed) is compressed, agreed
    assert '"type": "state"' in str(first) or '"type":"state"' in str(first)
