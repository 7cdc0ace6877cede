"""The recorder stage: per interaction, the participant's incoming frames and the agent's
outgoing frames (what the renderer sent) to two Parquet files.

``start_recording`` ``{"interaction_id", "directory"}`` opens
``<directory>/interaction-<id>-participant.parquet`` and ``...-agent.parquet`` (crash-safe
journals while recording, see :mod:`chameleons.worker.recording`). If those exist already —
a worker restarted mid-interaction and the server re-sent the command — the recording goes
on in ``...-part2`` (``-part3``...) and a journal the crash left behind is recovered first.
``stop_recording`` closes both and answers with their paths and frame counts; an
``event.recording`` event carries the same for the server to index.

A recording that cannot be written (read-only folder, full disk) is never silent: the
stage keeps ``problem`` (one sentence, :func:`write_problem`) in its stats, which the
heartbeat carries to the wizard's *Recording* chip, and publishes one ``recording_failed``
event per interaction for the server to flag it. A stream whose write failed is abandoned
(its chunks written before stay recoverable); later frames are counted in ``frames_lost``.
The problem stays until a recording starts cleanly again.
"""

from __future__ import annotations

import logging
import threading
import time
from collections import Counter
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import pyarrow as pa
import zmq

from chameleons.worker.control import (
    RESET_DELAY_PROBE,
    START_RECORDING,
    STOP_RECORDING,
    CommandError,
)
from chameleons.worker.delay_probe import DelayProbe
from chameleons.worker.envelope import EnvelopeError, Message, message_frame
from chameleons.worker.frames import BLENDSHAPE_INDEX, N_BLENDSHAPES, FaceFrame
from chameleons.worker.recording import (
    FrameRecorder,
    RecordingError,
    journal_path,
    recover_recording,
    write_problem,
)
from chameleons.worker.stage import (
    FINAL_LINGER_MS,
    PARTICIPANT_TOPIC,
    POLL_MS,
    SENT_TOPIC,
    CommandPort,
    Endpoints,
    receive_messages,
    send_message,
)

log = logging.getLogger(__name__)
STREAMS = ("participant", "agent")
STATS_INTERVAL = 1.0

# The brow raises the booth check watches (copied or left at neutral).
BROWS = [BLENDSHAPE_INDEX[n] for n in ("browInnerUp", "browOuterUpLeft", "browOuterUpRight")]


def recording_paths(directory: Path, interaction_id: str) -> dict[str, Path]:
    """The first free ``interaction-<id>[-partN]-<stream>.parquet`` pair in ``directory``."""
    for part in range(1, 1000):
        suffix = "" if part == 1 else f"-part{part}"
        paths = {s: directory / f"interaction-{interaction_id}{suffix}-{s}.parquet"
                 for s in STREAMS}  # fmt: skip
        if not any(_taken(path) for path in paths.values()):
            return paths
    raise CommandError("recording_exists", f"too many parts for interaction {interaction_id}")


def _taken(path: Path) -> bool:
    """Whether ``path`` holds a recording; a journal a crash left behind is recovered into
    it first (one the crash cut before its first chunk stays, unreadable, and is skipped)."""
    journal = journal_path(path)
    if journal.exists() and not path.exists():
        try:
            recover_recording(path)
        except RecordingError:
            log.warning("unrecoverable recording journal %s left in place", journal)
    return path.exists() or journal.exists()


class RecorderStage:
    name = "recorder"

    def __init__(self, context: zmq.Context[zmq.Socket[bytes]], endpoints: Endpoints,
                 *, booth: str = "",
                 processing: Mapping[str, Any] | None = None) -> None:  # fmt: skip
        self.context, self.endpoints, self.booth = context, endpoints, booth
        # How the booth processes the head (unit, mounting, mirror, re-centring): in every
        # recording's metadata, so a recorded frame traces back to it.
        self.processing = dict(processing or {})
        self.errors: Counter[str] = Counter()
        self.interaction: str | None = None
        self.recorders: dict[str, FrameRecorder] = {}
        self.failed: set[str] = set()  # streams abandoned after a write error
        self.frames_lost = 0
        self.problem: str | None = None
        self.probe = DelayProbe()
        self._pub: zmq.Socket[bytes] | None = None

    def run(self, stop: threading.Event) -> None:
        sub = self.context.socket(zmq.SUB)
        sub.setsockopt(zmq.LINGER, 0)
        for topic in (PARTICIPANT_TOPIC, SENT_TOPIC):
            sub.setsockopt(zmq.SUBSCRIBE, topic.encode())
        sub.connect(self.endpoints.participant)
        sub.connect(self.endpoints.render)
        self._pub = self.context.socket(zmq.PUB)
        self._pub.setsockopt(zmq.LINGER, 0)
        self._pub.bind(self.endpoints.recorder)
        port = CommandPort(self.context, self.endpoints.stage_control, self.name,
                           {START_RECORDING: self._start, STOP_RECORDING: self._stop,
                            RESET_DELAY_PROBE: self._reset_probe})  # fmt: skip
        poller = zmq.Poller()
        poller.register(sub, zmq.POLLIN)
        poller.register(port.socket, zmq.POLLIN)
        next_stats = time.monotonic() + STATS_INTERVAL
        try:
            while not stop.is_set():
                events = dict(poller.poll(POLL_MS))
                if sub in events:
                    for message in receive_messages(sub, self.errors):
                        self._record(message)
                if port.socket in events:
                    port.handle_pending()
                self._flush_due()
                if time.monotonic() >= next_stats:
                    next_stats += STATS_INTERVAL
                    self._send(Message("stats.recorder", "stats", 0, self.name,
                                       time.monotonic(), self.status()))  # fmt: skip
        finally:
            self._close_all()  # a clean stop keeps the files readable
            sub.close(linger=0)
            self._pub.close(linger=FINAL_LINGER_MS)
            port.close()

    def _send(self, message: Message) -> None:
        assert self._pub is not None
        send_message(self._pub, message)

    def _probe(self, message: Message) -> None:
        """Feed the copy-delay probe (booth check): captured yaw at capture time, the
        robot's yaw at send time."""
        try:
            if message.topic == PARTICIPANT_TOPIC:
                frame = message_frame(message)
                self.probe.captured(frame.capture_time, float(frame.head[0]))
                self.probe.brow_captured(frame.capture_time, float(frame.blendshapes[BROWS].max()))
            else:
                vector = message.array()
                self.probe.sent(message.time, float(vector[N_BLENDSHAPES]))
                self.probe.brow_sent(message.time, float(vector[BROWS].max()))
        except (EnvelopeError, KeyError, TypeError, ValueError, IndexError):
            pass  # counted by _record when recording; the probe just skips it

    def _reset_probe(self, _body: Mapping[str, Any]) -> Mapping[str, Any]:
        """The booth check starts its copy step: measure only the movement from now on
        (head movement while the robot ran another behaviour would blur the match)."""
        self.probe.reset()
        return {}

    def _record(self, message: Message) -> None:
        self._probe(message)
        if not self.recorders:
            return
        stream = "participant" if message.topic == PARTICIPANT_TOPIC else "agent"
        if stream in self.failed:
            self.frames_lost += 1
            return
        try:
            if stream == "participant":
                self.recorders[stream].write(message_frame(message))
            else:
                vector = message.array()
                due = float(message.body["t"])
                self.recorders[stream].write(FaceFrame.from_vector(
                    vector, due, message.time, "agent"))  # fmt: skip
        except (EnvelopeError, KeyError, TypeError, ValueError) as exc:
            self.errors[getattr(exc, "reason", "bad_frame")] += 1
        except (OSError, pa.ArrowException) as exc:
            self._write_failed(stream, exc)

    def _flush_due(self) -> None:
        """Frames buffered when the stream paused reach the journal within a chunk's time
        (:meth:`FrameRecorder.flush_if_due`); the loop wakes at least every ``POLL_MS``."""
        for stream, recorder in list(self.recorders.items()):
            if stream in self.failed:
                continue
            try:
                recorder.flush_if_due()
            except (OSError, pa.ArrowException) as exc:
                self._write_failed(stream, exc)

    def _write_failed(self, stream: str, exc: OSError | pa.ArrowException) -> None:
        """Abandon the stream, keep why, and tell the server once per interaction."""
        self.errors["write_failed"] += 1
        recorder = self.recorders[stream]
        recorder.abandon()
        self.failed.add(stream)
        error = exc if isinstance(exc, OSError) else OSError(str(exc))
        log.error("recording %s of interaction %s failed: %s", stream, self.interaction, exc)
        self._report(stream, write_problem(error, recorder.path.parent))

    def _report(self, stream: str, problem: str) -> None:
        """Keep the first problem of the interaction and tell the server about it."""
        if self.problem is not None:
            return
        self.problem = problem
        self._send(Message("event.recording", "recording_failed", 0, self.name,
                           time.monotonic(), {"interaction_id": self.interaction,
                                              "stream": stream, "reason": problem}))  # fmt: skip

    def _start(self, body: Mapping[str, Any]) -> Mapping[str, Any]:
        interaction = str(body["interaction_id"])
        if self.interaction == interaction:
            return self._files()  # already recording it: idempotent
        self._close_all()
        directory = Path(str(body["directory"]))
        try:
            directory.mkdir(parents=True, exist_ok=True)
            paths = recording_paths(directory, interaction)
            for stream, path in paths.items():
                metadata = {"interaction_id": interaction, "stream": stream, "booth": self.booth,
                            "head_processing": self.processing}  # fmt: skip
                self.recorders[stream] = FrameRecorder(path, metadata=metadata)
        except OSError as exc:
            self._close_all()
            self.problem = write_problem(exc, directory)
            raise CommandError("recording_failed", self.problem) from exc
        except ValueError as exc:
            self._close_all()
            raise CommandError("recording_failed", str(exc)) from exc
        self.interaction, self.problem, self.frames_lost = interaction, None, 0
        return self._files()

    def _stop(self, body: Mapping[str, Any]) -> Mapping[str, Any]:
        wanted = body.get("interaction_id")
        if wanted is not None and self.interaction is not None and str(wanted) != self.interaction:
            raise CommandError("not_recording", f"recording {self.interaction}, not {wanted}")
        return self._close_all()

    def _close_all(self) -> dict[str, Any]:
        if not self.recorders:
            return {"interaction_id": None, "files": {}}
        files, frames = {}, {}
        for stream, recorder in self.recorders.items():
            files[stream] = self._close_one(stream, recorder)
            frames[stream] = recorder.frames_written
        result: dict[str, Any] = {"interaction_id": self.interaction, "files": files,
                                  "frames": frames}  # fmt: skip
        if self.problem is not None:
            result.update(problem=self.problem, frames_lost=self.frames_lost)
        now = time.monotonic()
        self._send(Message("event.recording", "recording_stopped", 0, self.name, now,
                           {"worker_time": now, "wall_time": time.time(), **result}))  # fmt: skip
        self.recorders, self.interaction, self.failed = {}, None, set()
        return result

    def _close_one(self, stream: str, recorder: FrameRecorder) -> str:
        """The Parquet file, or the journal when the disk refuses the final write."""
        try:
            if stream in self.failed:
                recorder.abandon()
                return str(recover_recording(recorder.path))
            return str(recorder.close())
        except (OSError, RecordingError, pa.ArrowException) as exc:
            self.errors["close_failed"] += 1
            recorder.abandon()
            if isinstance(exc, OSError):
                self._report(stream, write_problem(exc, recorder.path.parent))
            return str(recorder.journal)

    def _files(self) -> dict[str, Any]:
        return {"interaction_id": self.interaction,
                "files": {s: str(r.path) for s, r in self.recorders.items()}}  # fmt: skip

    def status(self) -> dict[str, Any]:
        frames = {s: r.frames_written for s, r in self.recorders.items()}
        return {**self._files(), "frames": frames, "active": bool(self.recorders),
                "errors": dict(self.errors), "problem": self.problem,
                "frames_lost": self.frames_lost,
                "movement_delay": self.probe.measure(time.monotonic()),
                "movement_brows": self.probe.brows(time.monotonic())}  # fmt: skip
