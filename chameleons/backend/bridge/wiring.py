"""Starts the app's link to its workers for the lifetime of the server.

The bridge binds its ZeroMQ sockets (loopback unless configured), relays the virtual
robot's frames to the display pages and the pages' speech events back to the worker, starts
the booth flow (the robot and the recordings follow the session, outages reach the
timeline: :mod:`chameleons.backend.booth.flows`), and, in the embedded setup
(``embedded_worker``), supervises a local worker process.
"""

from __future__ import annotations

import logging
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from functools import partial

import zmq
from fastapi import FastAPI

from chameleons.backend.booth.flows import BoothFlow
from chameleons.backend.bridge.bridge import Bridge
from chameleons.backend.bridge.supervisor import WorkerSupervisor
from chameleons.backend.display.channel import get_display_channel
from chameleons.backend.display.media import lipsync_url_for
from chameleons.backend.display.relay import forward_speech_events, relay_envelope
from chameleons.settings import Settings
from chameleons.worker.envelope import Message

log = logging.getLogger(__name__)


def embedded_worker_args(settings: Settings) -> list[str]:
    """The local worker of the embedded setup: the virtual robot, the capture ports set."""
    return [
        "--driver", "virtual",
        "--livelink-port", str(settings.livelink_port),
        "--facecapturex-port", str(settings.facecapturex_port),
        "--keys-dir", str(settings.keys_dir.resolve()),
    ]  # fmt: skip


class WorkerLinkError(RuntimeError):
    """The worker link's sockets cannot be bound (one sentence, for the log and the CLI)."""


@asynccontextmanager
async def worker_link(app: FastAPI, settings: Settings) -> AsyncIterator[Bridge]:
    bridge = Bridge.from_settings(settings)
    try:
        await bridge.start()
    except zmq.ZMQError as exc:
        variables = "CHAMELEONS_WORKER_COMMAND_ENDPOINT and CHAMELEONS_WORKER_TELEMETRY_ENDPOINT"
        advice = (f"another chameleons server may be using them: stop it, or set {variables} "
                  "to free ones" if exc.errno == zmq.EADDRINUSE
                  else f"set {variables} to endpoints this computer can bind")  # fmt: skip
        why = zmq.strerror(exc.errno) if exc.errno else str(exc)
        raise WorkerLinkError(
            f"Cannot bind the worker endpoints {settings.worker_command_endpoint} and "
            f"{settings.worker_telemetry_endpoint} ({why}): {advice}."
        ) from exc
    app.state.bridge = bridge
    channel = get_display_channel(app)

    def relay(message: Message) -> None:
        # With the prompt's lip-sync URL the page moves the lips on the audio's own clock.
        relay_envelope(channel, message, lipsync_for=partial(lipsync_url_for, settings),
                       served_from=settings.effective_public_url)  # fmt: skip

    bridge.add_listener("display.", relay)
    forward_speech_events(channel, bridge.send_command)
    flow = app.state.booth_flow = BoothFlow(app.state).start(bridge)  # before any worker hello
    supervisor: WorkerSupervisor | None = None
    if settings.embedded_worker:
        supervisor = WorkerSupervisor(
            bridge, settings.embedded_worker_booth, embedded_worker_args(settings)
        )
        await supervisor.start()
        log.info("supervising a local worker for %s", settings.embedded_worker_booth)
    try:
        yield bridge
    finally:
        if supervisor is not None:
            await supervisor.stop()
        await flow.stop(drain_seconds=5.0)  # the worker's last recordings get indexed
        app.state.bridge = None
        await bridge.stop()
