"""The webcam benchmark's parts with tiny settings (seconds): a real worker tracking a video
file standing in for a camera, its renderer driving the probe driver; the camera source
unpaced; the command ``bench.all --worker`` would run."""

from __future__ import annotations

import importlib
import sys
from pathlib import Path
from typing import Any

import pytest

from bench import all as every
from bench.webcam_bench import RATE, camera_video, table, unpaced_fps, webcam_copy

pytestmark = pytest.mark.slow


def test_the_copy_delay_is_timed_from_the_camera_frame_to_the_probe_driver(
    tmp_path: Path,
) -> None:
    video = camera_video(tmp_path / "camera.mp4", 6.0)
    row = webcam_copy(video, 1.0, 0.5)
    assert row["samples"] > 0
    # The realised delay is the configured one to within a few frames on any machine.
    assert abs(row["head_ms"]["p50"]) < 100, row
    assert abs(row["face_ms"]["p50"]) < 100, row
    # Tracking takes time: the frame is mapped after it arrived, never before.
    assert 0 < row["tracking_ms"]["min"] <= row["tracking_ms"]["max"]
    assert 0 < row["paced_fps"] <= RATE * 1.2


def test_the_unpaced_camera_source_reads_the_whole_file(tmp_path: Path) -> None:
    row = unpaced_fps(camera_video(tmp_path / "short.mp4", 0.5))
    assert row["frames"] == round(0.5 * RATE)
    assert 0 < row["camera_source_fps"] < row["decode_only_fps"]  # tracking costs time


def test_the_table_prints_every_figure_beside_its_baseline() -> None:
    ms = {"min": 1.0, "p50": 2.0, "p99": 3.0, "max": 4.0}
    parts = [f"{part}{suffix}" for part in ("head", "face") for suffix in ("_ms", "_abs_ms")]
    copy: dict[str, Any] = dict.fromkeys(parts, ms)
    copy |= {"tracking_ms": ms, "paced_fps": 29.0}
    facemesh = {"detect_ms": 10.0, "detect_invoke_ms": 5.0, "tracked_frame_ms": 15.0,
                "landmarks_invoke_ms": 5.0, "mapping_ms": 1.0, "fps_640x480": 66.0}  # fmt: skip
    results = {"facemesh": facemesh, "delay": 4.0, "cpus": 2, "load_before": (1.0, 1.0, 1.0),
               "load_after": (2.0, 2.0, 2.0), "webcam_copy": copy, "iphone_copy": copy,
               "webcam_live": copy, "iphone_live": copy,
               "unpaced": {"camera_source_fps": 50.0, "decode_only_fps": 400.0}}  # fmt: skip
    printed = table(results)
    assert "copy 4 s |error| head p99 (ms)" in printed
    assert "0.12x" in printed  # 50 fps tracked against 400 decoded
    assert "load average before: 1.00, 1.00, 1.00; after: 2.00" in printed


def test_bench_all_with_the_worker_runs_it(tmp_path: Path) -> None:
    command = every.commands(True, tmp_path, worker=True)["webcam"]
    assert command[:3] == [sys.executable, "-m", "bench.webcam_bench"]
    args = importlib.import_module(command[2]).parser().parse_args(command[3:])
    assert args.quick
    assert args.json == tmp_path / "webcam.json"
