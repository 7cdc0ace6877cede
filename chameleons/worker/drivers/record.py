"""``record``: writes every driver call to a JSON-lines file, one object per line.

``{"t": <worker time>, "type": "face", "params": {"EYE_BLINK_LEFT": ...}}``,
``{"t", "type": "head", "yaw", "pitch", "roll"}``, ``play_audio``, ``stop_audio``,
``set_face``. Buffered; flushed about once a second and on close.
"""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import IO, Any, ClassVar

from chameleons.worker.drivers.base import Driver
from chameleons.worker.frames import BLENDSHAPE_NAMES, F32Array, upper_snake

_NAMES = tuple(upper_snake(n) for n in BLENDSHAPE_NAMES)
FLUSH_SECONDS = 1.0


class RecordDriver(Driver):
    name = "record"
    reports_speech_end: ClassVar[bool] = False

    def __init__(self, path: str | Path) -> None:
        super().__init__()
        self.path = Path(path)
        self._file: IO[str] | None = None
        self._flushed = 0.0

    def start(self) -> None:
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._file = self.path.open("a", encoding="utf-8", buffering=1 << 16)
        super().start()

    def close(self) -> None:
        if self._file is not None:
            self._file.close()
            self._file = None
        super().close()

    def _write(self, record: dict[str, Any]) -> None:
        if self._file is None:
            return
        now = time.monotonic()
        self._file.write(json.dumps({"t": now, **record}) + "\n")
        if now - self._flushed > FLUSH_SECONDS:
            self._file.flush()
            self._flushed = now

    def send_face(self, blendshapes: F32Array) -> None:
        self.faces_sent += 1
        values = (round(float(v), 5) for v in blendshapes)
        self._write({"type": "face", "params": dict(zip(_NAMES, values, strict=True))})

    def send_head(self, yaw: float, pitch: float, roll: float) -> None:
        self.heads_sent += 1
        self._write({"type": "head", "yaw": yaw, "pitch": pitch, "roll": roll})

    def play_audio(self, prompt_id: str, url: str, play_id: str | None = None) -> None:
        self._write({"type": "play_audio", "prompt_id": prompt_id, "url": url})
        super().play_audio(prompt_id, url, play_id)

    def stop_audio(self) -> None:
        self._write({"type": "stop_audio"})

    def set_face(self, face_id: str, renderer: str | None = None) -> None:
        self._write({"type": "set_face", "face_id": face_id, "renderer": renderer})
