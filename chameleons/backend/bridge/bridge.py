"""The server's end of the ZeroMQ link to the booth workers (asyncio, ``zmq.asyncio``).

The bridge binds a ROUTER (commands out, acks and hellos in) and a SUB (telemetry, events
and virtual-robot display frames in); workers connect to both (protocol:
:mod:`chameleons.worker.control`). It

- sends commands and awaits their acks (:meth:`Bridge.send_command`), raising
  :class:`WorkerTimeoutError` (a ``TimeoutError``) or :class:`WorkerUnavailableError`;
- tracks workers by their hellos and heartbeats (:meth:`Bridge.workers`,
  :meth:`Bridge.latest_telemetry`) and reports connects, restarts and losses as
  ``worker.<booth>`` messages (types ``worker_connected``, ``worker_restarted``,
  ``worker_lost``);
- fans everything out to async subscribers (:meth:`Bridge.subscribe`, bounded queues that
  drop the oldest display frame first) and to listeners (:meth:`Bridge.add_listener`);
- remembers each booth's state as set through it (behaviour, face, recording) and re-sends
  it when a worker comes back as a new instance (a restart).
"""

from __future__ import annotations

import asyncio
import errno
import inspect
import itertools
import logging
import time
from collections.abc import Awaitable, Callable
from pathlib import Path
from typing import Any

import zmq
import zmq.asyncio
from zmq.auth.asyncio import AsyncioAuthenticator

from chameleons.backend.bridge.state import BoothState, WorkerInfo
from chameleons.backend.bridge.subscriptions import Subscription
from chameleons.worker import curve as curve_keys
from chameleons.worker.control import (
    ACK_TOPIC,
    HELLO_TOPIC,
    Ack,
    CommandError,
    make_command,
    parse_ack,
)
from chameleons.worker.envelope import EnvelopeError, Message, deserialize, serialize

log = logging.getLogger(__name__)
Listener = Callable[[Message], Awaitable[None] | None]
DEFAULT_TIMEOUT = 2.0


class BridgeError(RuntimeError):
    """The bridge could not deliver a command."""


class WorkerUnavailableError(BridgeError):
    """No worker of that booth is connected."""


class WorkerTimeoutError(BridgeError, TimeoutError):
    """The worker did not acknowledge in time."""


class Bridge:
    def __init__(
        self, command_endpoint: str = "tcp://127.0.0.1:5555",
        telemetry_endpoint: str = "tcp://127.0.0.1:5556", *,
        context: zmq.asyncio.Context | None = None, stale_after: float = 3.0,
        replay_state: bool = True, curve: curve_keys.ServerKeys | None = None,
    ) -> None:  # fmt: skip
        self.command_endpoint, self.telemetry_endpoint = command_endpoint, telemetry_endpoint
        self.stale_after, self.replay_state = stale_after, replay_state
        self.curve = curve
        # CURVE needs the context's own authenticator (one per context): a context of its
        # own, made at start (a bridge never started holds nothing).
        self._given_context = context
        self._own_context = False
        self._context = context or zmq.asyncio.Context.instance()
        self._authenticator: AsyncioAuthenticator | None = None
        self._router: zmq.asyncio.Socket | None = None
        self._sub: zmq.asyncio.Socket | None = None
        self._tasks: list[asyncio.Task[None]] = []
        self._background: set[asyncio.Task[None]] = set()  # state replays
        self._pending: dict[int, tuple[str, asyncio.Future[Ack]]] = {}
        self._seq = itertools.count(1)
        self._workers: dict[str, WorkerInfo] = {}
        self._states: dict[str, BoothState] = {}
        self._subscriptions: set[Subscription] = set()
        self._listeners: list[tuple[str, Listener]] = []
        self.dropped: dict[str, int] = {}

    @classmethod
    def from_settings(cls, settings: Any) -> Bridge:
        """With the keys dir's server keys: CURVE. Without: loopback endpoints only (said
        in the log), anything else a :class:`~chameleons.worker.curve.CurveError`."""
        endpoints = [settings.worker_command_endpoint, settings.worker_telemetry_endpoint]
        keys_dir = Path(settings.keys_dir)
        if curve_keys.have_server_keys(keys_dir):
            log.info("worker link: CURVE with the keys in %s", keys_dir)
            return cls(*endpoints, curve=curve_keys.load_server(keys_dir))
        log.warning(curve_keys.require_safe(endpoints, who="server"))
        return cls(*endpoints)

    # --- lifecycle ---------------------------------------------------------------------------
    async def start(self) -> None:
        """Bind both sockets (a ``*`` port is resolved into the endpoint attributes)."""
        if self.curve is not None and self._given_context is None:
            self._context, self._own_context = zmq.asyncio.Context(), True
        router = self._context.socket(zmq.ROUTER)
        router.setsockopt(zmq.ROUTER_MANDATORY, 1)  # an absent worker is an error at once
        router.setsockopt(zmq.ROUTER_HANDOVER, 1)  # a restarted worker takes over its identity
        sub = self._context.socket(zmq.SUB)
        sub.setsockopt(zmq.SUBSCRIBE, b"")
        for socket in (router, sub):
            socket.setsockopt(zmq.LINGER, 0)
        if self.curve is not None:
            # Only workers whose public key is authorized get past the handshake.
            self._authenticator = AsyncioAuthenticator(self._context)
            self._authenticator.start()
            self._authenticator.configure_curve(domain="*", location=str(self.curve.authorized))
            for socket in (router, sub):
                curve_keys.apply_server(socket, self.curve)
        router.bind(self.command_endpoint)
        sub.bind(self.telemetry_endpoint)
        self.command_endpoint = router.getsockopt_string(zmq.LAST_ENDPOINT)
        self.telemetry_endpoint = sub.getsockopt_string(zmq.LAST_ENDPOINT)
        self._router, self._sub = router, sub
        for loop in (self._read_router(), self._read_sub(), self._watch()):
            self._tasks.append(asyncio.create_task(loop))

    async def stop(self) -> None:
        tasks = [*self._tasks, *self._background]
        for task in tasks:
            task.cancel()
        await asyncio.gather(*tasks, return_exceptions=True)
        self._tasks.clear()
        for _, future in self._pending.values():
            if not future.done():
                future.set_exception(BridgeError("the bridge stopped"))
        self._pending.clear()
        for socket in (self._router, self._sub):
            if socket is not None:
                socket.close(linger=0)
        self._router = self._sub = None
        if self._authenticator is not None:
            self._authenticator.stop()
            self._authenticator = None
        if self._own_context:
            self._own_context = False
            self._context.term()
        for subscription in list(self._subscriptions):
            subscription.close()

    async def __aenter__(self) -> Bridge:
        await self.start()
        return self

    async def __aexit__(self, *_exc: object) -> None:
        await self.stop()

    # --- commands ----------------------------------------------------------------------------
    async def send_command(
        self, booth: str, type: str, body: dict[str, Any] | None = None, *,
        timeout: float = DEFAULT_TIMEOUT,
    ) -> Ack:  # fmt: skip
        """Send a command and wait for its ack (``ok`` may be False: the worker refused)."""
        if self._router is None:
            raise BridgeError("the bridge is not running")
        seq = next(self._seq)
        future: asyncio.Future[Ack] = asyncio.get_running_loop().create_future()
        self._pending[seq] = (booth, future)
        message = make_command(type, body or {}, seq=seq)
        try:
            await self._router.send_multipart([booth.encode(), *serialize(message)])
            ack = await asyncio.wait_for(future, timeout)
        except zmq.ZMQError as exc:
            if exc.errno == errno.EHOSTUNREACH:
                raise WorkerUnavailableError(f"no worker of booth {booth!r} is connected") from exc
            raise BridgeError(f"cannot send to booth {booth!r}: {exc}") from exc
        except TimeoutError as exc:
            raise WorkerTimeoutError(
                f"the worker of booth {booth!r} did not answer {type} within {timeout:g} s"
            ) from exc
        finally:
            self._pending.pop(seq, None)
        if ack.ok:
            self._states.setdefault(booth, BoothState()).record(type, body or {})
        return ack

    async def relay(self, booth: str, message: Message) -> bool:
        """Send one envelope to a booth's worker without an ack (the capture page's frames:
        a late frame is a lost frame); False when it could not go (no such worker, or its
        queue is full: counted as ``relay_unreachable`` / ``relay_full``)."""
        if self._router is None:
            return False
        try:
            await self._router.send_multipart([booth.encode(), *serialize(message)],
                                              flags=zmq.NOBLOCK)  # fmt: skip
        except zmq.Again:
            self._count("relay_full")
            return False
        except zmq.ZMQError:
            self._count("relay_unreachable")
            return False
        return True

    # --- what the server reads ---------------------------------------------------------------
    def workers(self) -> dict[str, WorkerInfo]:
        return dict(self._workers)

    def state(self, booth: str) -> BoothState:
        return self._states.setdefault(booth, BoothState())

    def latest_telemetry(self, booth: str) -> tuple[dict[str, Any] | None, float | None]:
        info = self._workers.get(booth)
        if info is None or info.telemetry is None:
            return None, None
        return dict(info.telemetry), time.monotonic() - info.telemetry_at

    def subscribe(
        self, booth: str | None = None, kinds: tuple[str, ...] = ("telemetry", "event",
        "display", "worker"), *, limit: int = 256,
    ) -> Subscription:  # fmt: skip
        """An async iterator of messages (topics ``<kind>.<booth>``); close it when done."""
        subscription = Subscription(booth, kinds, limit, self._subscriptions.discard)
        self._subscriptions.add(subscription)
        return subscription

    def add_listener(self, prefix: str, listener: Listener) -> None:
        """Call ``listener(message)`` (sync or async) for every message whose topic starts
        with ``prefix``, e.g. ``"display."`` for the robot display relay."""
        self._listeners.append((prefix, listener))

    # --- receiving ---------------------------------------------------------------------------
    async def _read_router(self) -> None:
        assert self._router is not None
        while True:
            frames = await self._router.recv_multipart()
            identity, parts = frames[0].decode(errors="replace"), frames[1:]
            try:
                message = deserialize(parts)
                if message.topic == HELLO_TOPIC:
                    await self._on_hello(identity, message)
                elif message.topic == ACK_TOPIC:
                    self._on_ack(identity, parse_ack(message))
                else:
                    self._count("router_unknown_topic")
            except (EnvelopeError, CommandError):
                self._count("router_malformed")

    def _on_ack(self, booth: str, ack: Ack) -> None:
        self._seen(booth)
        pending = self._pending.get(ack.seq)
        if pending is None or pending[0] != booth:
            self._count("ack_unexpected")  # timed out already, or not ours
            return
        if not pending[1].done():
            pending[1].set_result(ack)

    async def _on_hello(self, booth: str, message: Message) -> None:
        instance = str(message.body.get("instance", ""))
        info = self._workers.get(booth)
        if info is None:
            info = self._workers[booth] = WorkerInfo(booth, instance, dict(message.body))
            await self._announce("worker_connected", info)
            if self.replay_state and self._states.get(booth):
                self._spawn_replay(booth)
        elif info.instance != instance:
            info.restart(instance, dict(message.body))
            await self._announce("worker_restarted", info)
            if self.replay_state:
                self._spawn_replay(booth)
        elif not info.connected(self.stale_after):
            await self._announce("worker_connected", info)
        info.hello = dict(message.body)
        self._seen(booth)

    def _spawn_replay(self, booth: str) -> None:
        task = asyncio.create_task(self._replay(booth))
        self._background.add(task)
        task.add_done_callback(self._background.discard)

    async def _replay(self, booth: str) -> None:
        """Re-send what this booth was told before its worker restarted."""
        for kind, body in self.state(booth).commands():
            try:
                ack = await self.send_command(booth, kind, body)
                if not ack.ok:
                    log.warning(
                        "replaying %s to %s refused: %s %s", kind, booth, ack.error, ack.detail
                    )
            except BridgeError as exc:
                log.warning("replaying %s to %s failed: %s", kind, booth, exc)
        info = self._workers.get(booth)
        if info is not None:
            info.replays += 1

    async def _read_sub(self) -> None:
        assert self._sub is not None
        while True:
            frames = await self._sub.recv_multipart()
            try:
                message = deserialize(frames)
            except EnvelopeError:
                self._count("sub_malformed")
                continue
            kind, _, booth = message.topic.partition(".")
            if not booth:
                self._count("sub_unknown_topic")
                continue
            if kind == "telemetry":
                info = self._workers.get(booth)
                if info is not None:
                    info.telemetry, info.telemetry_at = dict(message.body), time.monotonic()
                self._seen(booth)
            await self._dispatch(message, booth)

    async def _dispatch(self, message: Message, booth: str) -> None:
        for subscription in list(self._subscriptions):
            subscription.offer(message, booth)
        for prefix, listener in self._listeners:
            if message.topic.startswith(prefix):
                try:
                    result = listener(message)
                    if inspect.isawaitable(result):
                        await result
                except Exception:  # a listener's bug must not stop the bridge
                    log.exception("bridge listener for %r failed", prefix)

    def _seen(self, booth: str) -> None:
        info = self._workers.get(booth)
        if info is not None:
            info.last_seen = time.monotonic()
            info.lost_reported = False

    async def _watch(self) -> None:
        while True:
            await asyncio.sleep(self.stale_after / 4)
            for info in list(self._workers.values()):
                if not info.connected(self.stale_after) and not info.lost_reported:
                    info.lost_reported = True
                    await self._announce("worker_lost", info)

    async def _announce(self, kind: str, info: WorkerInfo) -> None:
        body = info.summary(self.stale_after)
        message = Message(f"worker.{info.booth}", kind, 0, "bridge", time.monotonic(), body)
        await self._dispatch(message, info.booth)

    def _count(self, reason: str) -> None:
        self.dropped[reason] = self.dropped.get(reason, 0) + 1


__all__ = ["Bridge", "BridgeError", "WorkerTimeoutError", "WorkerUnavailableError"]
