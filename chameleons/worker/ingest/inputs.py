"""Both capture inputs of a booth, started from settings: what the worker process runs."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import zmq

from chameleons.settings import Settings
from chameleons.worker.ingest.livelink import rotation_factor
from chameleons.worker.ingest.receivers import (
    PARTICIPANT_TOPIC,
    FaceCaptureXReceiver,
    LiveLinkReceiver,
)
from chameleons.worker.ingest.transform import FrameTransform


@dataclass(slots=True)
class CaptureInputs:
    livelink: LiveLinkReceiver
    facecapturex: FaceCaptureXReceiver

    def stop(self) -> None:
        self.livelink.stop()
        self.facecapturex.stop()

    def telemetry(self) -> dict[str, Any]:
        """Per-input counters plus the combined input frame rate, for the heartbeat."""
        live, fcx = self.livelink.stats.snapshot(), self.facecapturex.stats.snapshot()
        return {
            "input_fps": live["input_fps"] + fcx["input_fps"],
            "livelink": {**live, "port": self.livelink.port},
            "facecapturex": {**fcx, "port": self.facecapturex.port},
        }


def start_capture(
    settings: Settings,
    *,
    publish_endpoint: str,
    context: zmq.Context[zmq.Socket[bytes]] | None = None,
    bind_publisher: bool = False,
    host: str | None = None,
    livelink_port: int | None = None,
    facecapturex_port: int | None = None,
    topic: str = PARTICIPANT_TOPIC,
) -> CaptureInputs:
    """Start the Live Link (UDP) and FaceCaptureX (TCP) receivers publishing normalised
    frames to ``publish_endpoint``. Ports and host default to the settings; 0 = any free.
    With ``bind_publisher`` only one receiver can bind the endpoint, so that is refused."""
    if bind_publisher:
        raise ValueError("two receivers cannot bind one endpoint: let the consumer's SUB bind")
    common: dict[str, Any] = {
        "host": settings.capture_bind_host if host is None else host,
        "publish_endpoint": publish_endpoint,
        "context": context,
        "transform": FrameTransform.from_settings(settings),
        "topic": topic,
    }
    live = LiveLinkReceiver(
        port=settings.livelink_port if livelink_port is None else livelink_port,
        rotation_factor=rotation_factor(settings.livelink_rotation_scale),
        **common,
    )
    fcx = FaceCaptureXReceiver(
        port=settings.facecapturex_port if facecapturex_port is None else facecapturex_port,
        **common,
    )
    live.start()
    try:
        fcx.start()
    except BaseException:
        live.stop()
        raise
    return CaptureInputs(live, fcx)
