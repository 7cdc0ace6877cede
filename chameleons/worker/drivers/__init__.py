"""Robot drivers: ``virtual``, ``furhat``, ``virtual+furhat`` (both robots at one booth, the
condition's ``renderer`` choosing), ``record``, ``null``."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

from chameleons.worker.drivers.base import (
    ROBOT_STATE,
    SPEECH_END,
    SPEECH_START,
    Driver,
    DriverEvent,
)
from chameleons.worker.drivers.furhat import DEFAULT_URL, FurhatDriver
from chameleons.worker.drivers.null import NullDriver
from chameleons.worker.drivers.record import RecordDriver
from chameleons.worker.drivers.switch import (
    DEFAULT_FADE_SECONDS,
    DEFAULT_HOLD_SECONDS,
    FURHAT,
    SwitchDriver,
)
from chameleons.worker.drivers.virtual import Publish, VirtualDriver

DRIVER_NAMES = ("virtual", "furhat", "virtual+furhat", "record", "null")
_CLASSES: dict[str, type[Driver]] = {"virtual": VirtualDriver, "furhat": FurhatDriver,
                                     "virtual+furhat": SwitchDriver, "record": RecordDriver,
                                     "null": NullDriver}  # fmt: skip
DISPLAY_FACES = ("2d", "3d")  # a condition's renderer on the virtual display


def plays_wav(name: str) -> bool:
    """Whether the booth's robot needs the prompts as WAV (a Furhat cannot play MP3; with
    both robots the display's browser plays the WAV too)."""
    return name in ("furhat", "virtual+furhat")


def renderers(name: str) -> tuple[str, ...]:
    """The condition renderers a worker with driver ``name`` can run: the display's faces
    (a physical robot ignores them), and ``furhat`` where the booth drives a Furhat."""
    return (*DISPLAY_FACES, FURHAT) if name in ("furhat", "virtual+furhat") else DISPLAY_FACES


def speaks_text(name: str) -> bool:
    """Whether the robot of driver ``name`` speaks typed text with its own TTS."""
    driver = _CLASSES.get(name)
    return driver is not None and driver.speaks_text


@dataclass(frozen=True, slots=True)
class DriverOptions:
    booth: str = "booth-1"
    robot_url: str = DEFAULT_URL
    robot_key: str | None = None
    record_path: Path = Path("data/driver-record.jsonl")
    furhat_faces: Mapping[str, str] = field(default_factory=dict)  # study face id -> robot's
    # virtual+furhat: how the robot switched to wakes from its neutral (drivers.switch)
    switch_hold_seconds: float = DEFAULT_HOLD_SECONDS
    switch_fade_seconds: float = DEFAULT_FADE_SECONDS


def create_driver(name: str, options: DriverOptions, publish: Publish) -> Driver:
    """A driver by name; ``publish`` sends an envelope up the worker's PUB (virtual)."""
    if name == "virtual":
        return VirtualDriver(options.booth, publish)
    if name == "furhat":
        return FurhatDriver(options.robot_url, key=options.robot_key, faces=options.furhat_faces)
    if name == "virtual+furhat":
        return SwitchDriver(VirtualDriver(options.booth, publish),
                            create_driver("furhat", options, publish),
                            hold_seconds=options.switch_hold_seconds,
                            fade_seconds=options.switch_fade_seconds)  # fmt: skip
    if name == "record":
        return RecordDriver(options.record_path)
    if name == "null":
        return NullDriver()
    raise ValueError(f"unknown driver {name!r} (choose from {', '.join(DRIVER_NAMES)})")


__all__ = [
    "DEFAULT_URL",
    "DRIVER_NAMES",
    "ROBOT_STATE",
    "SPEECH_END",
    "SPEECH_START",
    "Driver",
    "DriverEvent",
    "DriverOptions",
    "FurhatDriver",
    "NullDriver",
    "Publish",
    "RecordDriver",
    "SwitchDriver",
    "VirtualDriver",
    "create_driver",
    "plays_wav",
    "renderers",
    "speaks_text",
]
