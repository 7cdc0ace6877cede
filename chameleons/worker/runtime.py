"""The worker process of one booth: capture -> behaviour -> renderer -> driver, plus playback,
recording and the control hub, each stage a thread talking over ZeroMQ.

With the default :class:`Endpoints` (``inproc://``) everything runs as threads of this
process; give ``ipc://``/``tcp://`` endpoints and the same stage classes run in separate
processes (each calls ``Stage(context, endpoints, ...).run(stop)``). A stage that crashes
stops the whole worker with a non-zero exit, so a supervisor restarts it cleanly.
"""

from __future__ import annotations

import faulthandler
import logging
import signal
import sys
import threading
import time
import uuid
from collections.abc import Callable, Mapping
from functools import partial
from pathlib import Path
from types import FrameType
from typing import TYPE_CHECKING, Any, Protocol

import zmq

from chameleons.worker.behaviour_stage import BehaviourStage, BehaviourStageConfig
from chameleons.worker.config import WorkerConfig as WorkerConfig
from chameleons.worker.control import CALIBRATE_WEBCAM, MARK_HEAD_REST, RESET_PAIRING
from chameleons.worker.drivers import renderers, speaks_text
from chameleons.worker.hub import ControlHub, HubConfig
from chameleons.worker.ingest.livelink import rotation_factor
from chameleons.worker.ingest.pairing import SenderLock
from chameleons.worker.playback import PlaybackStage
from chameleons.worker.recorder_stage import RecorderStage
from chameleons.worker.render_process import START_TIMEOUT as PROCESS_START_TIMEOUT
from chameleons.worker.render_process import (
    RendererProcess,
    cleanup,
    make_driver,
    process_endpoints,
)
from chameleons.worker.render_stage import DriverFactory, RendererStage
from chameleons.worker.stage import Endpoints, ParticipantBus

if TYPE_CHECKING:
    from chameleons.worker.ingest.browser import BrowserReceiver
    from chameleons.worker.ingest.webcam import LandmarkMapper
    from chameleons.worker.lsl_stage import LslStage

log = logging.getLogger(__name__)
START_TIMEOUT = 10.0
GIL_SWITCH_INTERVAL = 0.0005  # seconds
STOP_POLL_S = 0.2  # how often the main thread looks for a stop signal or a stage crash


class Stage(Protocol):
    name: str

    def run(self, stop: threading.Event) -> None: ...


class Receiver(Protocol):
    port: int
    stats: Any

    def start(self) -> Any: ...

    def stop(self, timeout: float = 5.0) -> None: ...


class Worker:
    """Builds the sockets and threads of one booth's pipeline; ``start``/``stop``."""

    def __init__(
        self, config: WorkerConfig, *, context: zmq.Context[zmq.Socket[bytes]] | None = None,
        driver_factory: DriverFactory | None = None,
    ) -> None:  # fmt: skip
        """``driver_factory``: the in-process renderer's driver instead of the configured one
        (a benchmark's probe); the renderer process always builds the configured driver."""
        self.config = config
        self._own_context = context is None
        self.context: zmq.Context[zmq.Socket[bytes]] = context or zmq.Context()
        self._own_endpoints = config.endpoints is None and config.renderer_process
        if config.endpoints is not None:
            self.endpoints = config.endpoints
        elif config.renderer_process:
            self.endpoints = process_endpoints(config.booth)
        else:
            self.endpoints = Endpoints.inproc(f"{config.booth}-{uuid.uuid4().hex[:8]}")
        self.stop_event = threading.Event()
        # The hub stops last, once the other stages have: it carries their last words out
        # (the robot's "closed", a recording's "stopped") to the server.
        self._hub_stop = threading.Event()
        self._hub_thread: threading.Thread | None = None
        self._stop_lock = threading.Lock()
        self._stopped = False
        self.failed = threading.Event()
        self.receivers: dict[str, Receiver] = {}
        self.pairing = SenderLock(config.capture_sender)
        self._threads: list[threading.Thread] = []
        self.bus = ParticipantBus(self.context, self.endpoints)
        self.behaviour = BehaviourStage(self.context, self.endpoints, BehaviourStageConfig(
            tick_rate=config.render.tick_rate, lookahead_ticks=config.lookahead_ticks,
            crossfade_seconds=config.crossfade_seconds, history_seconds=config.history_seconds,
            head_lead=config.head_lead, initial=config.behaviour,
            initial_params=config.initial_params(), locations=config,
            rotation_factor=rotation_factor(config.livelink_rotation_scale),
            recentre_head=config.head_recentre, head_calibration_s=config.head_calibration_s,
            mirror=config.mirror,
        ))  # fmt: skip
        self.playback = PlaybackStage(
            self.context,
            self.endpoints,
            speaks_text=speaks_text(config.driver),
            renderers=renderers(config.driver),
            driver=config.driver,
        )
        # In-process (the default) the renderer is a stage thread like the others.
        self.renderer: RendererStage | None = None
        renderer: RendererStage | RendererProcess
        if config.renderer_process:
            renderer = self.renderer_process = RendererProcess(config, self.endpoints)
        else:
            renderer = self.renderer = RendererStage(
                self.context,
                self.endpoints,
                driver_factory or partial(make_driver, config),
                config.render,
            )
        self.browser = self._browser_receiver()
        self.recorder = RecorderStage(self.context, self.endpoints, booth=config.booth,
                                      processing=config.head_processing())  # fmt: skip
        self.hub = ControlHub(self.context, self.endpoints, HubConfig(
            config.booth, config.command_endpoint, config.telemetry_endpoint,
            info={"driver": config.driver, "behaviour": config.behaviour,
                  "head": config.head_processing()}, curve=config.curve,
        ), ingest_stats=self.ingest_stats,
            local={RESET_PAIRING: lambda _body: self.pairing.reset(),
                   MARK_HEAD_REST: self.mark_head_rest,
                   CALIBRATE_WEBCAM: self.calibrate_webcam},
            capture=self.browser.offer if self.browser is not None else None)  # fmt: skip
        self._renderer_ready = renderer.ready
        self.stages: list[Stage] = [self.bus, self.behaviour, self.playback, renderer,
                                    self.recorder, self.hub]  # fmt: skip
        self.lsl: LslStage | None = None
        if config.lsl:
            from chameleons.instruments.lsl import require_pylsl
            from chameleons.worker.lsl_stage import LslStage

            require_pylsl()  # before any thread starts: a clear error, not a stage crash

            self.lsl = LslStage(self.context, self.endpoints, booth=config.booth,
                                tick_rate=config.render.tick_rate)  # fmt: skip
            self.stages.insert(-1, self.lsl)

    def _browser_receiver(self) -> BrowserReceiver | None:
        if not self.config.browser_capture:
            return None
        from chameleons.worker.ingest.browser import BrowserReceiver as Receiver
        from chameleons.worker.ingest.transform import FrameTransform

        return Receiver(publish_endpoint=self.endpoints.capture, context=self.context,
                               transform=FrameTransform(0.0, self.config.mirror),
                               mapper=self._webcam_mapper())  # fmt: skip

    def _webcam_mapper(self) -> LandmarkMapper:
        """A webcam's mapper: the geometric defaults, or the booth's iPhone-taught map."""
        from chameleons.facemesh.mapping import Calibration
        from chameleons.facemesh.teacher import map_from_json
        from chameleons.worker.ingest.webcam import LandmarkMapper as Mapper

        path = self.config.webcam_map
        if path is None:
            return Mapper()
        try:
            mapping = map_from_json(Path(path).read_text("utf-8"))
        except (OSError, ValueError, KeyError) as exc:
            raise ValueError(f"Cannot use the webcam map {path}: {exc}") from exc
        return Mapper(Calibration(mapping=mapping))

    def calibrate_webcam(self, body: Mapping[str, Any]) -> dict[str, Any]:
        """The capture page's neutral-face step (``calibrate_webcam``)."""
        if self.browser is None:
            return {"calibrated": False, "problem": "this worker takes no capture page"}
        result: dict[str, Any] = self.browser.calibrate(body)
        return result

    # --- lifecycle -------------------------------------------------------------------------
    def start(self) -> Worker:
        if self._threads:
            raise RuntimeError("this worker has been started already")
        for stage in self.stages:
            thread = threading.Thread(target=self._guard, args=(stage,),
                                      name=f"worker-{stage.name}", daemon=True)  # fmt: skip
            thread.start()
            self._threads.append(thread)
            if stage is self.hub:
                self._hub_thread = thread
        try:
            self._start_capture()
        except OSError:
            self.stop()
            raise
        timeout = PROCESS_START_TIMEOUT if self.config.renderer_process else START_TIMEOUT
        if not self._renderer_ready.wait(timeout) and not self.failed.is_set():
            self.stop()
            raise RuntimeError("the renderer did not start ticking")
        return self

    def _guard(self, stage: Stage) -> None:
        try:
            stage.run(self._hub_stop if stage is self.hub else self.stop_event)
        except Exception:
            log.exception("worker stage %s crashed: stopping the worker", stage.name)
            self.failed.set()
            self.stop_event.set()

    def _start_capture(self) -> None:
        from chameleons.worker.ingest.receivers import FaceCaptureXReceiver, LiveLinkReceiver
        from chameleons.worker.ingest.transform import FrameTransform

        cfg = self.config
        common: dict[str, Any] = {
            "host": cfg.capture_host, "publish_endpoint": self.endpoints.capture,
            "context": self.context,
            "transform": FrameTransform(cfg.mounting_rotation_deg, cfg.mirror),
            "pairing": self.pairing,
        }  # fmt: skip
        if cfg.livelink_port is not None:
            self.receivers["livelink"] = LiveLinkReceiver(
                port=cfg.livelink_port,
                rotation_factor=rotation_factor(cfg.livelink_rotation_scale), **common,
            ).start()  # fmt: skip
        if cfg.facecapturex_port is not None:
            receiver = FaceCaptureXReceiver(port=cfg.facecapturex_port, **common)
            self.receivers["facecapturex"] = receiver.start()
        if self.browser is not None:
            self.receivers["webcam-browser"] = self.browser.start()
        if cfg.camera is not None:
            from chameleons.worker.ingest.webcam import CameraReceiver

            camera = CameraReceiver(device=cfg.camera, publish_endpoint=self.endpoints.capture,
                                    context=self.context, transform=common["transform"],
                                    mapper=self._webcam_mapper())  # fmt: skip
            self.receivers["webcam"] = camera.start()

    def ingest_stats(self) -> dict[str, Any]:
        snapshots = {name: getattr(r, "snapshot", r.stats.snapshot)()
                     for name, r in self.receivers.items()}  # fmt: skip
        drops: dict[str, int] = {}
        for name, snap in snapshots.items():
            for reason, count in snap.get("drops", {}).items():
                drops[f"{name}.{reason}"] = count
        fps = max((s.get("input_fps", 0.0) for s in snapshots.values()), default=0.0)
        no_face = any(s.get("no_face_recent") for s in snapshots.values())
        problem = next((s["problem"] for s in snapshots.values() if s.get("problem")), None)
        heads = [s["head_range"] for s in snapshots.values() if s.get("head_range")]
        head_range = max(heads, key=lambda h: h["frames"]) if heads else None
        # Which input the face comes from: the busiest one, else the only one configured.
        busiest = max(snapshots, key=lambda n: snapshots[n].get("input_fps", 0.0), default=None)
        page = snapshots.get("webcam-browser", {})
        active = busiest if busiest and snapshots[busiest].get("input_fps") else (
            "webcam-browser" if page.get("connected") else
            "webcam" if "webcam" in snapshots else None)  # fmt: skip
        timecodes = [s["timecode"] for s in snapshots.values() if s.get("timecode")]
        untrusted = next((t for t in timecodes if t.get("problem")), None)
        return {"input_fps": fps, "drops": drops, "receivers": snapshots,
                "no_face": no_face, "problem": problem, "head_range": head_range,
                "pairing": self.pairing.snapshot(), "source": active,
                # Why the capture runs on arrival times (None: the sender's clock is used).
                "timecode_problem": untrusted["detail"] if untrusted else None}  # fmt: skip

    def mark_head_rest(self, body: Mapping[str, Any]) -> dict[str, Any]:
        """The booth check: the resting head pose is the mean of the last ``rest_seconds``
        (per input; the one with the most frames answers)."""
        seconds = float(body["rest_seconds"])
        rests = [r.stats.mark_rest(seconds) for r in self.receivers.values()]
        measured = [rest for rest in rests if rest is not None]
        return {"rest": max(measured, key=lambda r: r["frames"]) if measured else None}

    def stop(self, timeout: float = 5.0) -> None:
        """Stop every stage (the hub last) and free the sockets; a second call does nothing."""
        with self._stop_lock:
            if self._stopped:
                return
            self._stopped = True
        self.stop_event.set()
        for receiver in self.receivers.values():
            try:
                receiver.stop(timeout)
            except RuntimeError:
                log.exception("capture receiver did not stop")
        for thread in self._threads:
            if thread is not self._hub_thread:
                thread.join(timeout)
        self._hub_stop.set()
        if self._hub_thread is not None:
            self._hub_thread.join(timeout)
        if self._own_context:
            self.context.term()
        if self._own_endpoints:
            cleanup(self.endpoints)

    def __enter__(self) -> Worker:
        return self.start()

    def __exit__(self, *_exc: object) -> None:
        self.stop()


def run_worker(config: WorkerConfig, *, echo: Callable[[str], None] = print) -> int:
    """Run until SIGINT/SIGTERM (or a stage crash); returns the process exit code: 128 + the
    signal that stopped it (130, 143), else 1 after a stage crash."""
    # A thread that wakes for a tick must get the GIL quickly; Python's default hand-over
    # interval (5 ms) would show up directly as tick jitter. This process is the worker's own.
    sys.setswitchinterval(GIL_SWITCH_INTERVAL)
    worker = Worker(config)
    previous: dict[int, Any] = {}
    signals: list[int] = []

    def request_stop(signum: int, _frame: FrameType | None) -> None:
        # Only a note: the handler runs in the main thread between two of its bytecodes, and
        # ``Event.set()`` here deadlocked when the signal came while that thread was inside
        # ``Event.wait()`` holding the event's lock (a server killed hard: its SIGTERM came
        # so, and the worker outlived it). The loop below sees the note.
        signals.append(signum)

    for signum in (signal.SIGINT, signal.SIGTERM):
        previous[int(signum)] = signal.signal(signum, request_stop)
    # `kill -USR1 <worker>` prints every thread's stack to stderr: where a worker that does
    # not stop, or stalls, is waiting (docs/hardware/booth-pc.md, "A worker that hangs").
    dump_signal = getattr(signal, "SIGUSR1", None)  # not on Windows
    if dump_signal is not None:
        faulthandler.register(dump_signal, all_threads=True)
    try:
        worker.start()
        ports = ", ".join(f"{n} port {r.port}" if r.port else n  # webcams: no port
                          for n, r in worker.receivers.items())  # fmt: skip
        echo(f"worker {config.booth}: driver {config.driver}, behaviour {config.behaviour}, "
             f"{ports or 'no capture'}; control {config.command_endpoint}; "
             "Ctrl-C stops")  # fmt: skip
        # Polled, not ``stop_event.wait()``: see ``request_stop``. ``time.sleep`` is resumed
        # after a handler (PEP 475), so a signal is seen within one nap.
        while not signals and not worker.stop_event.is_set():
            time.sleep(STOP_POLL_S)
    finally:
        worker.stop()
        for number, handler in previous.items():
            signal.signal(number, handler)
        if dump_signal is not None:
            faulthandler.unregister(dump_signal)
    if worker.failed.is_set():
        echo("worker stopped after a stage failure (see the log)")
    if signals:  # stopped on request: the conventional 128 + signal (130 Ctrl-C, 143 TERM)
        return 128 + signals[0]
    return 1 if worker.failed.is_set() else 0


if __name__ == "__main__":  # pragma: no cover - `python -m chameleons.worker.runtime`
    sys.exit(run_worker(WorkerConfig()))
