"""Robot drivers: ``virtual``, ``furhat``, ``record``, ``null``."""

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
from chameleons.worker.drivers.virtual import Publish, VirtualDriver

DRIVER_NAMES = ("virtual", "furhat", "record", "null")
_CLASSES: dict[str, type[Driver]] = {"virtual": VirtualDriver, "furhat": FurhatDriver,
                                     "record": RecordDriver, "null": NullDriver}  # fmt: skip


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


def create_driver(name: str, options: DriverOptions, publish: Publish) -> Driver:
    """A driver by name; ``publish`` sends an envelope up the worker's PUB (virtual)."""
    if name == "virtual":
        return VirtualDriver(options.booth, publish)
    if name == "furhat":
        return FurhatDriver(options.robot_url, key=options.robot_key, faces=options.furhat_faces)
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
    "VirtualDriver",
    "create_driver",
    "speaks_text",
]
