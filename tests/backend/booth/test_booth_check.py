"""The booth check: each step judged against the expected sign and size, and the whole
check through a real bridge and worker fed a head turn and nod over real Live Link UDP."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import pytest
from fastapi import FastAPI
from sqlalchemy import select

from chameleons.backend.booth import check
from chameleons.backend.bridge import Bridge
from chameleons.backend.models import BoothCheck
from tests.backend.booth.conftest import (
    BOOTH,
    new_session,
    running_worker,
    timeline,
    until,
    worker_config,
)
from tests.support.bots import StaffApi
from tests.worker.livelink_recording import head_turn_then_nod
from tests.worker.test_livelink_replay import _replay


def beat(yaw: tuple[float, float], pitch_max: float, **extra: Any) -> dict[str, Any]:
    heads = {"yaw_min": yaw[0], "yaw_max": yaw[1], "pitch_min": 0.0, "pitch_max": pitch_max,
             "frames": 480}  # fmt: skip
    return {"input_fps": 60.0, "capture_to_send_ms": 9.0, "ingest": {"head_range": heads},
            **extra}  # fmt: skip


def test_a_left_turn_and_a_nod_of_the_right_size_pass() -> None:
    result = check.head_turn(beat((-2.0, 41.0), 14.0))
    assert result["status"] == "pass"
    assert result["figures"]["yaw_max"] == 41.0
    assert result["value"] == "yaw +41, pitch +14 degrees"


@pytest.mark.parametrize(
    ("yaw", "pitch", "why"),
    [((-41.0, 2.0), 14.0, "wrong way"), ((-3.0, 125.0), 44.0, "rotation unit"),
     ((-1.0, 4.0), 14.0, "no turn"), ((-1.0, 40.0), 1.0, "no nod")],
)  # fmt: skip
def test_sign_unit_and_missing_movement_errors_are_named(
    yaw: tuple[float, float], pitch: float, why: str
) -> None:
    result = check.head_turn(beat(yaw, pitch))
    assert result["status"] == "fail"
    assert why in result["value"]


def test_without_a_worker_every_worker_step_fails_and_disk_is_judged(tmp_path: Path) -> None:
    result = check.run(None, None, tmp_path)
    steps = {s["id"]: s for s in result["steps"]}
    assert result["passed"] is False
    assert steps["face"]["value"] == "no worker for this booth"
    assert steps["disk"]["status"] == "pass" or "below" in steps["disk"]["value"]
    assert check.disk(tmp_path, minimum=2**62)["status"] == "warn"  # a free-space warning


def test_the_disk_step_needs_a_session_of_recordings_and_a_writable_folder(
    tmp_path: Path,
) -> None:
    from chameleons.settings import Settings

    settings = Settings(recording_rate_bytes_per_s=1_000, session_length_minutes=30)
    assert settings.session_disk_bytes == 1_800_000  # rate x session length
    enough = check.disk(tmp_path, settings.session_disk_bytes)
    assert enough["status"] == "pass"
    assert enough["figures"]["needed_bytes"] == 1_800_000
    assert "a session needs about 2 MB" in enough["value"]
    short = check.disk(tmp_path, minimum=2**62)
    assert short["status"] == "warn"
    assert "below the" in short["value"]
    if os.geteuid() != 0:  # root writes through permissions (the reliability suite mounts)
        (tmp_path / "recordings").mkdir()
        (tmp_path / "recordings").chmod(0o555)
        try:
            refused = check.disk(tmp_path)
        finally:
            (tmp_path / "recordings").chmod(0o755)
        assert refused["status"] == "fail"
        assert "is read-only" in refused["value"]


@pytest.mark.usefixtures("flow")
def test_the_check_through_a_real_worker_sees_the_head_turn_and_is_stored(
    app: FastAPI, pi: StaffApi, study_id: int, bridge: Bridge, tmp_path: Path
) -> None:
    wizard, _ = new_session(pi, study_id)
    config = worker_config(bridge, tmp_path, behaviour="copy", livelink_port=0)
    with running_worker(bridge, config) as worker:
        _replay(worker.receivers["livelink"].port, head_turn_then_nod(40.0, 15.0).packets)

        def heartbeat_has_the_turn() -> bool:
            telemetry, _ = bridge.latest_telemetry(BOOTH)
            heads = ((telemetry or {}).get("ingest") or {}).get("head_range") or {}
            return float(heads.get("yaw_max", 0.0)) > 35.0

        until(heartbeat_has_the_turn, what="the head turn in the heartbeat")
        # The robot's copy of the turn comes 4 s later: the worker measures it then.
        until(lambda: (bridge.latest_telemetry(BOOTH)[0] or {}).get("movement_delay"),
              timeout=30, what="the measured copy delay")  # fmt: skip
        result = pi.post(f"/api/booths/{BOOTH}/check?session_id={wizard.session_id}")
    steps = {s["id"]: s for s in result["steps"]}
    assert steps["head"]["status"] == "pass", steps["head"]
    assert 35.0 < steps["head"]["figures"]["yaw_max"] <= 40.5
    assert 12.0 < steps["head"]["figures"]["pitch_max"] <= 15.5
    assert steps["robot"]["status"] == "pass"
    assert steps["copy"]["figures"]["delay_s"] == 4.0
    assert steps["copy"]["status"] == "pass", steps["copy"]
    assert abs(steps["copy"]["figures"]["measured_s"] - 4.0) <= 0.25
    assert [s["id"] for s in result["steps"]] == ["face", "head", "robot", "copy", "speech",
                                                   "disk"]  # fmt: skip
    stored = next(e for e in timeline(wizard) if e["kind"] == "booth.checked")
    assert stored["payload"]["steps"] == result["steps"]
    with app.state.sessionmaker() as db:
        row = db.scalars(select(BoothCheck).where(BoothCheck.session_id == wizard.session_id)).one()
    assert row.measured_delay_s == steps["copy"]["figures"]["measured_s"]
    assert (row.copy_delay_s, row.booth, row.passed) == (4.0, BOOTH, result["passed"])
    assert row.head_yaw_deg == steps["head"]["figures"]["yaw_max"]
