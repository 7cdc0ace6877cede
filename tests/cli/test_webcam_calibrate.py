"""``chameleons webcam-calibrate``: a video of a real face photo (moving: real landmark
noise) and a take recorded "at the same time" teach a map the worker can load. The take
here is the webcam's own geometric reading of the same video (``chameleons face-track``):
a teacher whose values are a (clipped) linear function of the features, which the fit must
recover on held-out frames. Bad input is refused with one sentence."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
from click.testing import CliRunner

from chameleons.cli.main import cli
from chameleons.facemesh.teacher import map_from_json
from chameleons.worker.runtime import Worker, WorkerConfig
from tests.support.faces import Motion, scene
from tests.support.videos import write_video


def moving_face(path: Path, frames: int = 150) -> Path:
    motions = [Motion(angle=12 * np.sin(k / 8), scale=1 + 0.15 * np.sin(k / 11),
                      dx=round(20 * np.sin(k / 13))) for k in range(frames)]  # fmt: skip
    return write_video(path, [scene("astronaut", m) for m in motions])


def test_a_map_is_taught_reported_written_and_loaded_by_the_worker(tmp_path: Path) -> None:
    video = moving_face(tmp_path / "webcam.mp4")
    take = tmp_path / "iphone.csv"
    runner = CliRunner()
    tracked = runner.invoke(cli, ["face-track", str(video), "--out", str(take)])
    assert tracked.exit_code == 0, tracked.output
    out = tmp_path / "map.json"
    result = runner.invoke(cli, ["webcam-calibrate", str(video), str(take), "--out", str(out),
                                 "--neutral-seconds", "1"])  # fmt: skip
    assert result.exit_code == 0, result.output
    body = json.loads(out.read_text("utf-8"))
    mapping = map_from_json(out.read_text("utf-8"))
    assert mapping.name.startswith("iphone:")
    assert f"map {mapping.name}" in result.output
    assert body["frames"]["test"] >= 10
    agreement = {a["channel"]: a for a in body["agreement"]}
    assert "cheekPuff" not in agreement  # never derived: never taught
    best = max(a["r2"] for a in agreement.values() if np.isfinite(a["r2"]))
    assert best > 0.8, agreement
    config = WorkerConfig(booth="booth-map", driver="null", livelink_port=None,
                          facecapturex_port=None, webcam_map=out,
                          command_endpoint="inproc://no-server-commands",
                          telemetry_endpoint="inproc://no-server-telemetry")  # fmt: skip
    worker = Worker(config)
    try:
        assert worker.browser is not None
        assert worker.browser.mapper.snapshot()["map"] == mapping.name
    finally:
        worker.stop()


def test_bad_input_is_refused_with_one_sentence(tmp_path: Path) -> None:
    runner = CliRunner()
    empty = write_video(tmp_path / "empty.mp4", [scene("astronaut", Motion(face=False))] * 10)
    take = tmp_path / "take.csv"
    take.write_text("not,a,take\n1,2,3\n", "utf-8")
    refused = runner.invoke(cli, ["webcam-calibrate", str(empty), str(take), "--out",
                                  str(tmp_path / "m.json")])  # fmt: skip
    assert refused.exit_code == 1
    assert refused.output.startswith("Error: ")
    assert len(refused.output.strip().splitlines()) == 1
    video = moving_face(tmp_path / "short.mp4", frames=30)
    tracked = runner.invoke(cli, ["face-track", str(video), "--out", str(take)])
    assert tracked.exit_code == 0, tracked.output
    too_few = runner.invoke(cli, ["webcam-calibrate", str(video), str(take), "--out",
                                  str(tmp_path / "m.json")])  # fmt: skip
    assert too_few.exit_code == 1
    assert "fall inside the iPhone take" in too_few.output
    assert not (tmp_path / "m.json").exists()
