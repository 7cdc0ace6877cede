"""A booth that copies the participant, for tests: a real worker (Live Link on a free UDP
port, the copy behaviour, the Furhat driver to its test peer) and the server's end of the
control link (:class:`ControlPeer`). Not a test module."""

from __future__ import annotations

import contextlib
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import Any

import zmq

from chameleons.worker.runtime import Worker, WorkerConfig
from tests.worker.control_peer import ControlPeer
from tests.worker.furhat_peer import FurhatPeer


@dataclass
class CopyBooth:
    worker: Worker
    robot: FurhatPeer
    server: ControlPeer

    @property
    def port(self) -> int:
        return self.worker.receivers["livelink"].port

    def heads(self, since: float, axis: str) -> list[float]:
        """The robot's head angle ``axis`` (yaw, pitch, roll) in every head pose since then."""
        return [float(r.message[axis]) for r in self.robot.of_type("request.face.headpose")
                if r.time >= since]  # fmt: skip

    def heartbeat(self, condition: Callable[[dict[str, Any]], bool] = lambda body: True
                  ) -> dict[str, Any]:  # fmt: skip
        """The newest heartbeat the server peer received that meets ``condition``."""

        def found() -> dict[str, Any] | None:
            beats = [m.body for m in self.server.of_type("heartbeat") if condition(m.body)]
            return beats[-1] if beats else None

        body: dict[str, Any] = self.server.wait(found, timeout=10)
        return body


@contextlib.contextmanager
def copy_booth(booth: str, **config: Any) -> Iterator[CopyBooth]:
    """The booth ``booth`` running ``copy`` (same side: mirror off) with ``config`` on top."""
    context: zmq.Context[zmq.Socket[bytes]] = zmq.Context()
    server = ControlPeer(context)
    with FurhatPeer() as robot:
        settings: dict[str, Any] = {
            "booth": booth, "driver": "furhat", "robot_url": robot.url, "behaviour": "copy",
            "mirror": False, "livelink_port": 0, "facecapturex_port": None,
            "capture_host": "127.0.0.1", "command_endpoint": server.command_endpoint,
            "telemetry_endpoint": server.telemetry_endpoint, **config,
        }  # fmt: skip
        worker = Worker(WorkerConfig(**settings), context=context).start()
        try:
            robot.wait_for(lambda p: bool(p.of_type("request.face.config")), timeout=10)
            yield CopyBooth(worker, robot, server)
        finally:
            worker.stop()
            server.close()
    context.term()
