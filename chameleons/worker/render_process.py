"""The renderer (and the robot driver it owns) in a process of its own.

In one process the renderer's tick thread competes for the GIL with capture, behaviour,
playback, recording and the control hub: its median tick is within 10 microseconds of a
bare loop but its p99 is set by wake-up latency behind those threads (docs/performance.md).
``chameleons worker --renderer-process`` moves the renderer to a child process that holds
only its own two threads; the stages talk over ``ipc://`` sockets instead of ``inproc://``.
Optionally the child asks for real-time scheduling (``--realtime``: SCHED_FIFO, which needs
CAP_SYS_NICE or an rtprio limit) and a CPU of its own (``--renderer-cpu N``); what the
system refused is logged, and the renderer runs on at normal priority.

The child stops when the worker stops, and also when the worker dies without stopping it
(``kill -9``): it watches its parent. A child that dies stops the worker (non-zero exit), as
any crashed stage does.
"""

from __future__ import annotations

import contextlib
import logging
import multiprocessing
import os
import signal
import sys
import tempfile
import threading
import uuid
from collections.abc import Mapping
from functools import partial
from multiprocessing.connection import Connection
from pathlib import Path
from typing import Any, Protocol

import zmq

from chameleons.worker.drivers import DriverOptions, Publish, create_driver
from chameleons.worker.render_stage import RendererStage
from chameleons.worker.renderer import RenderConfig
from chameleons.worker.stage import Endpoints

log = logging.getLogger(__name__)
START_TIMEOUT = 60.0  # a spawned child imports NumPy, SciPy and ZeroMQ before its first tick
STOP_TIMEOUT = 5.0
REALTIME_PRIORITY = 10  # low among real-time priorities: above every normal process
GIL_SWITCH_INTERVAL = 0.0005


class RendererProcessConfig(Protocol):
    """What the child needs of the worker's configuration (``config.WorkerConfig`` has it):
    the robot driver's options, the renderer's, and the child's scheduling wishes. The
    runtime starts this process, so this module names what it reads rather than importing
    the runtime back."""

    @property
    def booth(self) -> str: ...
    @property
    def driver(self) -> str: ...
    @property
    def robot_url(self) -> str: ...
    @property
    def robot_key(self) -> str | None: ...
    @property
    def furhat_faces(self) -> Mapping[str, str]: ...
    @property
    def data_dir(self) -> Path: ...
    @property
    def render(self) -> RenderConfig: ...
    @property
    def switch_hold_seconds(self) -> float: ...
    @property
    def switch_fade_seconds(self) -> float: ...
    @property
    def renderer_realtime(self) -> bool: ...
    @property
    def renderer_cpu(self) -> int | None: ...


def make_driver(config: RendererProcessConfig, publish: Publish) -> Any:
    options = DriverOptions(booth=config.booth, robot_url=config.robot_url,
                            robot_key=config.robot_key,
                            record_path=config.data_dir / f"driver-{config.booth}.jsonl",
                            furhat_faces=config.furhat_faces,
                            switch_hold_seconds=config.switch_hold_seconds,
                            switch_fade_seconds=config.switch_fade_seconds)  # fmt: skip
    return create_driver(config.driver, options, publish)


def process_endpoints(booth: str) -> Endpoints:
    """``ipc://`` endpoints in a fresh private folder (removed by ``cleanup``)."""
    folder = Path(tempfile.mkdtemp(prefix="chameleons-ipc-"))
    return Endpoints.ipc(f"{booth}-{uuid.uuid4().hex[:8]}", folder)


def cleanup(endpoints: Endpoints) -> None:
    folders = {Path(e.removeprefix("ipc://")).parent for e in vars_of(endpoints)}
    for folder in folders:
        for sock in folder.glob("*.sock"):
            sock.unlink(missing_ok=True)
        with contextlib.suppress(OSError):
            folder.rmdir()


def vars_of(endpoints: Endpoints) -> list[str]:
    return [getattr(endpoints, name) for name in endpoints.__slots__]


def apply_scheduling(realtime: bool, cpu: int | None) -> list[str]:
    """Ask for the renderer's CPU and real-time priority; sentences for what was refused."""
    notes: list[str] = []
    if cpu is not None:
        try:
            os.sched_setaffinity(0, {cpu})
        except (OSError, ValueError) as exc:
            notes.append(f"the renderer could not be pinned to CPU {cpu} ({exc})")
    if realtime:
        try:
            os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(REALTIME_PRIORITY))
        except OSError as exc:
            notes.append(f"real-time scheduling was not permitted ({exc}); normal priority")
    return notes


class PipeFlag:
    """``wait(timeout)`` until the other end writes or closes. Pipes, not multiprocessing
    Events: an Event's lock held by a process that is killed stays held, and the survivor's
    ``set()`` would wait forever (seen when the renderer was killed mid-``wait``)."""

    def __init__(self, reader: Connection) -> None:
        self._reader = reader

    def wait(self, timeout: float | None = None) -> bool:
        return bool(self._reader.poll(timeout))


class RendererProcess:
    """A worker stage whose ``run`` starts the renderer's process and watches it."""

    name = "renderer"

    def __init__(self, config: RendererProcessConfig, endpoints: Endpoints) -> None:
        spawn = multiprocessing.get_context("spawn")  # no copy of this process's threads
        ready_reader, ready_writer = spawn.Pipe(duplex=False)
        stop_reader, self._stop_writer = spawn.Pipe(duplex=False)
        self.ready = PipeFlag(ready_reader)
        # The child stops when this end is written or closed: by ``run``, or by the kernel
        # when this process dies.
        self.process = spawn.Process(
            target=_child_main,
            args=(config, endpoints, stop_reader, ready_writer),
            name=f"chameleons-renderer-{config.booth}",
            daemon=True,
        )

    def run(self, stop: threading.Event) -> None:
        self.process.start()
        try:
            while not stop.wait(0.2):
                if not self.process.is_alive():
                    raise RuntimeError(f"the renderer process exited ({self.process.exitcode})")
        finally:
            self._stop_writer.close()
            self.process.join(STOP_TIMEOUT)
            if self.process.is_alive():
                self.process.kill()
                self.process.join(STOP_TIMEOUT)


def _child_main(
    config: RendererProcessConfig,
    endpoints: Endpoints,
    stop_reader: Connection,
    ready_writer: Connection,
) -> None:
    # A terminal's Ctrl-C reaches the whole process group: the worker stops this process
    # through the pipe, in order, rather than have it die with a traceback first.
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    logging.basicConfig(level=logging.INFO, format="%(levelname)s %(name)s: %(message)s")
    sys.setswitchinterval(GIL_SWITCH_INTERVAL)
    for note in apply_scheduling(config.renderer_realtime, config.renderer_cpu):
        log.warning(note)
    context: zmq.Context[zmq.Socket[bytes]] = zmq.Context()
    stage = RendererStage(context, endpoints, partial(make_driver, config), config.render)
    stop = threading.Event()

    def watch() -> None:
        # The worker's stop, or the worker gone (kill -9 closes its end of the pipe too).
        told = False
        while not stop.is_set():
            if stop_reader.poll(0.2):
                stop.set()
            if stage.ready.is_set() and not told:
                ready_writer.send_bytes(b"ready")
                told = True

    threading.Thread(target=watch, name="renderer-watch", daemon=True).start()
    try:
        stage.run(stop)
    finally:
        context.term()
