"""The app's worker link as `chameleons demo` runs it: a real bridge, a real supervised
worker process (virtual robot), and the display page's WebSocket receiving its frames."""

from __future__ import annotations

import json
from typing import Any

import anyio
import pytest
from fastapi.testclient import TestClient

from chameleons.backend.app import create_app
from chameleons.backend.display.tokens import display_token, signing_key
from chameleons.settings import Settings

BOOTH = "booth-1"


@pytest.fixture
def database_url(sqlite_template: object, tmp_path: object) -> str:
    """One backend is enough: this is about processes and sockets, not SQL."""
    import shutil
    from pathlib import Path

    path = Path(str(tmp_path)) / "link.sqlite3"
    shutil.copyfile(str(sqlite_template), path)
    return f"sqlite:///{path}"


@pytest.fixture
def embedded_settings(settings: Settings) -> Settings:
    return settings.model_copy(
        update={
            "bridge_enabled": True,
            "embedded_worker": True,
            "worker_command_endpoint": "tcp://127.0.0.1:*",
            "worker_telemetry_endpoint": "tcp://127.0.0.1:*",
            "livelink_port": 0,
            "facecapturex_port": 0,
        }
    )


async def _first_telemetry(bridge: Any) -> dict[str, Any]:
    subscription = bridge.subscribe(BOOTH, ("telemetry",))
    try:
        with anyio.fail_after(20):
            async for message in subscription:
                return dict(message.body)
    finally:
        subscription.close()
    raise AssertionError("the subscription ended without telemetry")


def test_embedded_worker_heartbeats_and_drives_the_display(embedded_settings: Settings) -> None:
    app = create_app(embedded_settings)
    with TestClient(app) as client:
        bridge, portal = app.state.bridge, client.portal
        assert bridge is not None
        assert portal is not None
        assert bridge.command_endpoint.startswith("tcp://127.0.0.1:")  # loopback only
        telemetry = portal.call(_first_telemetry, bridge)
        assert BOOTH in bridge.workers()
        assert "tick_rate" in json.dumps(telemetry)
        token = display_token(signing_key(app), BOOTH)
        with client.websocket_connect(f"/ws/display/{BOOTH}?token={token}") as ws:
            assert ws.receive_json()["type"] == "hello"
            ack = portal.call(bridge.send_command, BOOTH, "set_face", {"face_id": "face-3"})
            assert ack.ok
            for _ in range(2000):  # face/head frames stream meanwhile; bounded read
                message = ws.receive_json()
                if message["type"] == "set_face":
                    assert message["face"] == "face-3"
                    break
            else:
                pytest.fail("the display never received the set_face command")
    assert app.state.bridge is None
