"""The server-worker ZeroMQ link with CURVE (issue 15): only a worker holding an authorized
key pair gets through; a client without the key, or with a key the server never authorized,
cannot inject anything. Before CURVE, one injected ``recording_stopped`` event got a file
from outside the data directory indexed as a recording (the plain link below shows that the
injection itself is well-formed: there it is delivered)."""

from __future__ import annotations

import asyncio
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
import zmq
from fastapi import FastAPI
from fastapi.testclient import TestClient
from sqlalchemy import select

from chameleons.backend.bridge import Bridge
from chameleons.backend.models import Recording
from chameleons.worker import curve
from chameleons.worker.envelope import Message, serialize
from tests.backend.booth.conftest import (
    ANY_PORT,
    BOOTH,
    new_session,
    running_worker,
    until,
    wait_for_event,
    worker_config,
)
from tests.support.bots import StaffApi


@pytest.fixture
def keys(tmp_path: Path) -> Path:
    folder = tmp_path / "keys"
    curve.create_keys(folder)
    return folder


@pytest.fixture
def bridge(app: FastAPI, client: TestClient, keys: Path) -> Iterator[Bridge]:
    """The conftest's bridge, with CURVE on (the server keys of ``keys``)."""
    assert client.portal is not None
    bridge = Bridge(ANY_PORT, ANY_PORT, stale_after=0.6, curve=curve.load_server(keys))
    client.portal.call(bridge.start)
    app.state.bridge = bridge
    yield bridge
    app.state.bridge = None
    client.portal.call(bridge.stop)


INJECTED = Path("/etc/passwd")  # the control's path: a file outside any data directory


def injected(interaction_id: int, outside: Path) -> list[bytes]:
    body = {"interaction_id": interaction_id, "files": {"participant": str(outside)},
            "frames": {"participant": 100}}  # fmt: skip
    message = Message(f"event.{BOOTH}", "recording_stopped", 1, "recorder", time.monotonic(), body)
    return serialize(message)


def inject(endpoint: str, frames: list[bytes], until_seen: Any, *, keys: curve.ClientKeys | None
           = None, seconds: float = 1.5) -> None:  # fmt: skip
    """Publish ``frames`` to the server's telemetry socket again and again (a PUB drops what
    it sends before its connection is up) until ``until_seen()`` or ``seconds`` pass."""
    context = zmq.Context()
    pub = context.socket(zmq.PUB)
    pub.setsockopt(zmq.LINGER, 0)
    if keys is not None:
        curve.apply_client(pub, keys)
    pub.connect(endpoint)
    deadline = time.monotonic() + seconds
    try:
        while time.monotonic() < deadline and not until_seen():
            pub.send_multipart(frames)
            time.sleep(0.05)
    finally:
        pub.close(linger=0)
        context.term()


def delivered(seen: list[Message], path: Path) -> bool:
    """The injected ``recording_stopped`` (naming ``path``) arrived. The real worker sends
    its own ``recording_stopped`` when it stops (its files are in the data directory): that
    one got through CURVE legitimately and is not the injection."""
    return any(
        m.type == "recording_stopped" and str(path) in m.body.get("files", {}).values()
        for m in seen
    )


def outside_file(tmp_path: Path) -> Path:
    secret = tmp_path / "elsewhere" / "interaction-1-participant.parquet"
    secret.parent.mkdir()
    secret.write_bytes(b"PAR1 not a recording of this study")
    return secret


def indexed(app: FastAPI) -> list[str]:
    with app.state.sessionmaker() as db:
        return list(db.scalars(select(Recording.path)))


@pytest.mark.usefixtures("flow")
def test_a_client_without_the_key_cannot_inject_a_recording(
    app: FastAPI, pi: StaffApi, study_id: int, bridge: Bridge, keys: Path, tmp_path: Path
) -> None:
    wizard, _ = new_session(pi, study_id)
    config = worker_config(bridge, tmp_path, curve=curve.load_client(keys))
    outside = outside_file(tmp_path)
    seen: list[Message] = []
    bridge.add_listener("event.", seen.append)
    # A key pair the server never authorized, with the server's public key (not secret).
    stranger_keys = tmp_path / "stranger"
    curve.create_keys(stranger_keys, "stranger")
    (stranger_keys / "server.key").write_bytes((keys / "server.key").read_bytes())
    stranger = curve.load_client(stranger_keys, "stranger")
    with running_worker(bridge, config):  # the authorized worker gets through (its hello)
        wizard.start()
        wizard.advance(1, "discussion")
        started = wait_for_event(wizard, "recording.started")
        frames = injected(started["interaction_id"], outside)
        inject(bridge.telemetry_endpoint, frames, lambda: delivered(seen, outside))  # no key at all
        inject(bridge.telemetry_endpoint, frames, lambda: delivered(seen, outside), keys=stranger)
        beats = until(lambda: bridge.latest_telemetry(BOOTH)[0], what="the worker's heartbeat")
    assert beats["booth"] == BOOTH  # CURVE let the real worker in
    assert not delivered(seen, outside)
    assert str(outside) not in indexed(app)
    assert not any("elsewhere" in path for path in indexed(app))


def test_the_same_injection_gets_through_a_plain_link() -> None:
    """The control: without CURVE the injected message is delivered (what the CURVE test
    keeps out is a real message, not a malformed one)."""
    seen: list[Message] = []

    async def main() -> None:
        bridge = Bridge(ANY_PORT, ANY_PORT)
        bridge.add_listener("event.", seen.append)
        await bridge.start()
        try:
            frames = injected(1, INJECTED)
            await asyncio.to_thread(inject, bridge.telemetry_endpoint, frames,
                                    lambda: delivered(seen, INJECTED), seconds=20.0)  # fmt: skip
        finally:
            await bridge.stop()

    asyncio.run(main())
    assert delivered(seen, INJECTED)


def test_without_keys_only_loopback_endpoints_are_allowed() -> None:
    note = curve.require_safe(["tcp://127.0.0.1:5555", "ipc:///tmp/x"], who="server")
    assert "unauthenticated, on loopback only" in note
    with pytest.raises(curve.CurveError, match="reachable from the network"):
        curve.require_safe(["tcp://0.0.0.0:5555"], who="server")
    with pytest.raises(curve.CurveError, match="chameleons keys create"):
        curve.require_safe(["tcp://192.168.1.20:5556"], who="worker")


def test_keys_create_writes_the_pairs_and_refuses_to_overwrite(tmp_path: Path) -> None:
    from click.testing import CliRunner

    from chameleons.cli.main import cli

    folder = tmp_path / "keys"
    made = CliRunner().invoke(cli, ["keys", "create", "--keys-dir", str(folder)])
    assert made.exit_code == 0, made.output
    names = {p.name for p in folder.iterdir()}
    assert {"server.key", "server.key_secret", "worker.key", "worker.key_secret"} <= names
    assert (folder / "authorized" / "worker.key").is_file()
    assert oct((folder / "worker.key_secret").stat().st_mode & 0o777) == "0o600"
    again = CliRunner().invoke(cli, ["keys", "create", "--keys-dir", str(folder)])
    assert again.exit_code == 1
    assert "exists" in again.output
    booth = CliRunner().invoke(cli, ["keys", "create", "--keys-dir", str(folder),
                                     "--worker", "booth-2"])  # fmt: skip
    assert booth.exit_code == 0, booth.output
    assert (folder / "authorized" / "booth-2.key").is_file()
    assert curve.load_server(folder).public == curve.load_client(folder, "booth-2").server_public


def test_an_unkeyed_server_refuses_an_endpoint_on_the_network(tmp_path: Path) -> None:
    from chameleons.settings import Settings

    exposed = Settings(data_dir=tmp_path, worker_command_endpoint="tcp://0.0.0.0:5555")
    with pytest.raises(curve.CurveError, match="chameleons keys create"):
        Bridge.from_settings(exposed)
    curve.create_keys(tmp_path / "keys")
    assert Bridge.from_settings(exposed).curve is not None  # keys present: CURVE, allowed
