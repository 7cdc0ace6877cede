"""A booth worker's configuration (``chameleons worker``'s options and the demo's): its
booth, robot, capture sources, head processing, behaviour, renderer and links to the
server. :mod:`.runtime` runs a worker from it."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from chameleons.worker.curve import ClientKeys
from chameleons.worker.drivers import DEFAULT_URL
from chameleons.worker.drivers.switch import hold_seconds_for
from chameleons.worker.renderer import HeadFilter, RenderConfig
from chameleons.worker.stage import Endpoints


@dataclass(frozen=True, slots=True)
class WorkerConfig:
    booth: str = "booth-1"
    driver: str = "virtual"
    robot_url: str = DEFAULT_URL
    robot_key: str | None = None
    furhat_faces: Mapping[str, str] = field(default_factory=dict)  # study face id -> Furhat's
    data_dir: Path = Path("data")
    prompts_dir: Path | None = None  # None: as the server's (chameleons.prompts.locations)
    command_endpoint: str = "tcp://127.0.0.1:5555"
    telemetry_endpoint: str = "tcp://127.0.0.1:5556"
    capture_host: str = "0.0.0.0"
    capture_sender: str | None = None  # None: the first sender after a reset
    livelink_port: int | None = 11111  # None: no Live Link receiver (0: any free port)
    facecapturex_port: int | None = 19977
    camera: str | None = None  # a local camera (or a video file) the worker tracks itself
    browser_capture: bool = True  # the capture page's webcam frames, relayed by the server
    webcam_map: Path | None = None  # an iPhone-taught map (chameleons webcam-calibrate)
    livelink_rotation_scale: str = "radians"
    mounting_rotation_deg: float = 0.0
    mirror: bool = True
    head_recentre: bool = True  # copy re-centres the head on the participant's neutral pose
    head_calibration_s: float = 20.0  # that neutral: the mean of this many seconds of frames
    behaviour: str = "still"
    behaviour_params: Mapping[str, Any] = field(default_factory=dict)
    copy_delay: float = 4.0
    render: RenderConfig = field(default_factory=RenderConfig)
    crossfade_seconds: float = 0.3
    history_seconds: float = 12.0
    lookahead_ticks: int = 5
    endpoints: Endpoints | None = None  # None: inproc (ipc with renderer_process), unique
    curve: ClientKeys | None = None  # CURVE keys of the link to the server (None: plain)
    # The renderer and driver in a child process (chameleons.worker.render_process), with
    # SCHED_FIFO and a CPU of its own where the system permits.
    renderer_process: bool = False
    renderer_realtime: bool = False
    renderer_cpu: int | None = None
    # LSL outlets of the participant's and the robot's faces (docs/instruments.md).
    lsl: bool = False

    def initial_params(self) -> dict[str, Any]:
        if self.behaviour == "copy" and not self.behaviour_params.get("coexpress"):
            return {"delay": self.copy_delay, **self.behaviour_params}
        return dict(self.behaviour_params)

    def head_processing(self) -> dict[str, Any]:
        """How this booth turns the phone's head pose into the robot's: with the recordings
        and the worker's hello, so recorded data traces back to it."""
        return {"rotation_scale": self.livelink_rotation_scale,
                "mounting_rotation_deg": self.mounting_rotation_deg, "mirror": self.mirror,
                "recentre": self.head_recentre,
                "calibration_s": self.head_calibration_s}  # fmt: skip

    @property
    def switch_hold_seconds(self) -> float:
        """virtual+furhat: how long the robot switched to stays at its neutral
        (``drivers.switch.hold_seconds_for``)."""
        return hold_seconds_for(self.crossfade_seconds,
                                self.lookahead_ticks / self.render.tick_rate)  # fmt: skip

    @property
    def switch_fade_seconds(self) -> float:
        """virtual+furhat: then it fades into its frames over as long as a crossfade."""
        return self.crossfade_seconds

    @property
    def head_lead(self) -> float:
        render = self.render
        return HeadFilter(render.fir_taps, render.fir_cutoff_hz, render.tick_rate).group_delay
