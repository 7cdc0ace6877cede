"""``chameleons demo --webcam``: the demo prints the booth's capture link (and its QR code),
starts no simulated face, and frames sent on that link's WebSocket (as the capture page
sends them) reach the demo's own worker process: the PI monitor then reads the booth's
face input as coming from the webcam."""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Any

import httpx
import numpy as np
from websockets.sync.client import connect

from chameleons.backend.capture.relay import HEADER
from chameleons.backend.sessions.bot import StaffApi
from chameleons.facemesh.pose import canonical_landmarks
from tests.cli.test_demo_command import Demo, _launch, _stop
from tests.cli.test_demo_command import demos as demos  # the fixture: ends what a test left

BOOTH = "booth-1"


def page_frame(ms: float) -> bytes:
    points = canonical_landmarks(640, 480).astype("<f4")
    return HEADER.pack(ms, ms + 30, 640, 480, len(points)) + points.tobytes()


def input_check(pi: StaffApi) -> dict[str, Any]:
    booths = pi.get("/api/pi/monitor")["booths"]
    checks: list[dict[str, Any]] = next(
        (b["health"]["checks"] for b in booths if b["booth"] == BOOTH), []
    )
    return next((c for c in checks if c["id"] == "input"), {})


def test_the_webcam_demo_prints_the_capture_link_and_its_worker_takes_the_frames(
    tmp_path: Path, demos: list[Demo]
) -> None:
    data_dir = tmp_path / "data"
    data_dir.mkdir()
    demo = _launch(data_dir, True, ("--webcam",), {})
    demos.append(demo)
    demo.read_welcome()
    demo.wait_healthy()
    text = "\n".join(demo.output)
    line = next(x for x in demo.output if x.strip().startswith("webcam capture"))
    url = line.split()[-1]
    assert url.startswith(f"{demo.base}/capture/{BOOTH}/")
    assert "Webcam capture link as a QR code" in text
    assert "The webcam on the capture page is the face source" in text
    assert httpx.get(url, timeout=10).status_code == 200
    token = url.rsplit("/", 1)[1]
    ws_url = demo.base.replace("http", "ws", 1) + f"/ws/capture/{BOOTH}?token={token}"
    with httpx.Client(base_url=demo.base, timeout=10) as http, connect(ws_url) as socket:
        assert json.loads(socket.recv(timeout=10)) == {"type": "hello", "booth": BOOTH}
        pi = StaffApi(http).login("pi", demo.accounts["pi"])
        start, deadline = time.monotonic(), time.monotonic() + 60
        while "from the webcam" not in str(input_check(pi).get("value")):
            assert time.monotonic() < deadline, input_check(pi)
            for _ in range(10):  # a third of a second of frames at 30 fps
                socket.send(page_frame((time.monotonic() - start) * 1000))
                time.sleep(1 / 30)
        assert input_check(pi)["ok"] is True
        assert np.isfinite(float(str(input_check(pi)["value"]).split()[0]))
    _stop(demo, {"chameleons.cli.worker_command"})
