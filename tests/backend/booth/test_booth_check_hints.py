"""The booth check names the likely cause where a failing step would otherwise mislead
(issue 28), through a real bridge and worker fed Live Link UDP:

- a head rotation read in the wrong unit (the phone's radians read as degrees, or
  degrees/180 read as radians) makes a real turn look far too small: the step says "no turn
  seen" *and* that the unit is the likely cause;
- "Robot copies the head" is measured on what the worker sends, which it computes whether
  or not the robot takes it: with a Furhat that refuses the login the step passed. It fails
  with the login failure as its reason.
"""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from chameleons.backend.bridge import Bridge
from chameleons.settings import Settings
from tests.backend.booth.conftest import (
    BOOTH,
    new_session,
    running_worker,
    until,
    worker_config,
)
from tests.backend.booth.test_booth_check import (
    TURN_AND_NOD,
    acknowledged_behaviour,
    check_in_background,
    phone_ready,
    running_behaviour,
)
from tests.support.bots import StaffApi
from tests.worker.furhat_peer import FurhatPeer
from tests.worker.head_stream import Pose, stream_after

pytestmark = pytest.mark.usefixtures("flow")


@pytest.fixture
def settings(settings: Settings) -> Settings:
    """A shorter head movement than a technician's (the replayed turn and nod take 3 s)."""
    return settings.model_copy(update={"booth_check_rest_seconds": 1.0,
                                       "booth_check_turn_seconds": 2.5,
                                       "booth_check_nod_seconds": 2.0})  # fmt: skip


@pytest.mark.parametrize(
    ("scale", "turn", "meant", "how"),
    [("degrees", 40.0, 40.0, "the phone sends radians and the worker reads degrees: 57.3 times"),
     # Degrees/180 on the wire (an Unreal app's publisher) read as radians: the packets
     # carry 40/180, which the recording's radians writer gives for a turn of 40/pi degrees.
     ("radians", 40.0 / math.pi, 40.0,
      "the phone sends degrees/180 and the worker reads radians: 3.14 times")],
    ids=["radians_read_as_degrees", "degrees_180_read_as_radians"],
)  # fmt: skip
def test_a_turn_read_in_the_wrong_unit_fails_with_the_unit_as_the_likely_cause(
    pi: StaffApi, bridge: Bridge, tmp_path: Path, scale: str, turn: float, meant: float,
    how: str,
) -> None:  # fmt: skip
    config = worker_config(bridge, tmp_path, livelink_port=0, livelink_rotation_scale=scale)
    # The technician holds still (the resting pose), turns and nods, as the check asks.
    pose = Pose(turn_at=0.3, turn_deg=turn, turn_s=1.5, nod_at=2.0, nod_deg=15.0, nod_s=1.0)
    with running_worker(bridge, config) as worker:
        until(lambda: running_behaviour(bridge) == "still", what="the worker in still")
        checking, answer = check_in_background(pi, f"/api/booths/{BOOTH}/check?say=false")
        stream_after(worker.receivers["livelink"].port, pose, 3.5, phone_ready(worker),
                     until=lambda: not checking.is_alive())  # fmt: skip
        checking.join(timeout=90)
    assert "error" not in answer, answer
    head = next(s for s in answer["steps"] if s["id"] == "head")
    assert head["status"] == "fail"
    value = str(head["value"])
    assert ": no turn to the left seen; if the head moved about " in value
    said = float(value.split("if the head moved about ")[1].split("°")[0])
    assert abs(said - meant) <= 2.0, value
    assert f"the rotation unit is wrong ({how} too small)" in value
    assert value.endswith("check CHAMELEONS_LIVELINK_ROTATION_SCALE")


def test_a_robot_that_refuses_the_login_fails_the_copy_step_with_the_login_failure(
    pi: StaffApi, study_id: int, bridge: Bridge, tmp_path: Path
) -> None:
    wizard, _ = new_session(pi, study_id)
    with FurhatPeer(access=False) as robot:
        config = worker_config(bridge, tmp_path, livelink_port=0, driver="furhat",
                               robot_url=robot.url, robot_key="wrong")  # fmt: skip
        with running_worker(bridge, config) as worker:
            until(lambda: (bridge.latest_telemetry(BOOTH)[0] or {}).get("robot_state")
                  == "auth_refused", what="the refused login")  # fmt: skip
            checking, answer = check_in_background(
                pi, f"/api/booths/{BOOTH}/check?session_id={wizard.session_id}&say=false"
            )
            copying = {"name": "copy", "params": {"delay": 4.0}}
            until(lambda: acknowledged_behaviour(bridge) == copying, what="the switch to copy")
            stream_after(worker.receivers["livelink"].port, TURN_AND_NOD, 3.5,
                         phone_ready(worker), until=lambda: not checking.is_alive())  # fmt: skip
            checking.join(timeout=90)
    assert not checking.is_alive()
    assert "error" not in answer, answer
    steps = {s["id"]: s for s in answer["steps"]}
    assert steps["head"]["status"] == "pass", steps["head"]  # the phone side is fine
    copy = steps["copy"]
    assert copy["status"] == "fail", copy
    refused = "login refused: the robot refused the login (wrong or missing key)"
    assert copy["value"] == ("delay 4.00 s configured (copy: copies everything, 4 s late, "
                             "mirror image); checked on the Furhat; the robot cannot copy: "
                             f"{refused}")  # fmt: skip
    assert answer["checked_on"] == "Checked on the Furhat"
    assert steps["robot"]["status"] == "fail"
    assert answer["passed"] is False
