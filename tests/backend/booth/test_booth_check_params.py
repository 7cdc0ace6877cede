"""The booth check runs any copy condition of the study with its full parameters (issue 31):
the technician picks it, the worker is sent the condition's params (with the wizard path's
seed rule), and the check judges what it can: a head-only copy copies the head turn and not
the brows, a jittered delay lies within its distribution's range. Through a real bridge and
worker fed a head turn, nod and brow raise over real Live Link UDP."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest
from fastapi import FastAPI
from sqlalchemy import select

from chameleons.backend.booth import check, check_copy
from chameleons.backend.bridge import Bridge
from chameleons.backend.models import Interaction
from chameleons.settings import Settings
from tests.backend.booth.conftest import BOOTH, new_session, running_worker, until, worker_config
from tests.backend.booth.test_booth_check import (
    acknowledged_behaviour,
    check_in_background,
    phone_ready,
    running_behaviour,
)
from tests.experiment.study_files import default_document, study_yaml
from tests.support.bots import StaffApi, study_with_plan
from tests.worker.head_stream import Pose, stream_after

HEAD_ONLY = {"channels": "head", "delay": 1.0}
JITTER = {"delay": {"uniform": [0.5, 1.5]}}
HALF = {"channels": ["head", "brows"], "gain": 0.5, "delay": 1.0}
# A turn, a nod and a brow raise, all within the check's movement (turn 2.5 s + nod 2 s).
MOVES = Pose(turn_at=0.3, turn_deg=40.0, turn_s=1.5, nod_at=2.0, nod_deg=15.0, nod_s=1.0,
             brow_at=3.1, brow=0.6, brow_s=1.0)  # fmt: skip


@pytest.fixture
def settings(settings: Settings) -> Settings:
    return settings.model_copy(update={"booth_check_rest_seconds": 1.0,
                                       "booth_check_turn_seconds": 2.5,
                                       "booth_check_nod_seconds": 2.0})  # fmt: skip


@pytest.fixture
def params_study(pi: StaffApi) -> int:
    document = default_document()
    document["conditions"] = {
        "head_only": {"label": "Head only", "behaviour": "copy", "params": HEAD_ONLY},
        "jitter": {"label": "Jittered", "behaviour": "copy", "params": JITTER},
        "half": {"label": "Half", "behaviour": "copy", "params": HALF},
        "still": {"label": "Still", "behaviour": "still"},
    }  # fmt: skip
    return study_with_plan(pi, participants=6, yaml=study_yaml(document))


def run_check(pi: StaffApi, bridge: Bridge, tmp_path: Path, condition: str,
              expected: dict[str, Any]) -> dict[str, Any]:  # fmt: skip
    with running_worker(bridge, worker_config(bridge, tmp_path, livelink_port=0)) as worker:
        until(lambda: running_behaviour(bridge) == "still", what="the worker in still")
        checking, answer = check_in_background(
            pi, f"/api/booths/{BOOTH}/check?say=false&condition={condition}"
        )
        until(lambda: acknowledged_behaviour(bridge) == {"name": "copy", "params": expected},
              what="the check's switch to the condition")  # fmt: skip
        stream_after(worker.receivers["livelink"].port, MOVES, 4.3, phone_ready(worker),
                     until=lambda: not checking.is_alive())  # fmt: skip
        checking.join(timeout=90)
        assert not checking.is_alive()
        until(lambda: running_behaviour(bridge) == "still", what="still restored")
    assert "error" not in answer, answer
    step: dict[str, Any] = next(s for s in answer["steps"] if s["id"] == "copy")
    return step


@pytest.mark.usefixtures("flow")
def test_a_head_only_condition_copies_the_head_turn_and_not_the_brows(
    pi: StaffApi, params_study: int, bridge: Bridge, tmp_path: Path
) -> None:
    new_session(pi, params_study)  # the booth's study
    plan = pi.get(f"/api/booths/{BOOTH}/check?condition=head_only")
    assert plan["behaviour_words"] == "copies head, 1 s late, mirror image"
    assert plan["prompts"][2]["text"] == "Nod (chin down and up), then raise your eyebrows"
    assert [c["id"] for c in plan["conditions"]] == ["head_only", "jitter", "half"]
    step = run_check(pi, bridge, tmp_path, "head_only", HEAD_ONLY)
    assert step["status"] == "pass", step
    assert abs(step["figures"]["measured_s"] - 1.0) <= check.MAX_DELAY_ERROR_S
    brows = step["figures"]["brows"]
    assert brows["captured"] >= check_copy.BROWS_MOVED  # the brows were raised ...
    assert brows["sent"] < check_copy.BROWS_STILL  # ... and the robot's stayed at neutral
    assert "brows not copied, as configured" in step["value"]
    assert "(head_only: copies head, 1 s late, mirror image)" in step["value"]
    # Gain 1: the robot's turn as large as the technician's.
    assert "gain 1 realised on the head turn" in step["value"]
    assert step["figures"]["measured_gain"] == pytest.approx(1.0, abs=check_copy.GAIN_TOLERANCE)


@pytest.mark.usefixtures("flow")
def test_a_gain_is_judged_on_the_head_turn_and_the_brows(
    pi: StaffApi, params_study: int, bridge: Bridge, tmp_path: Path
) -> None:
    """Gain 0.5 on the head and brows: the robot turns and raises its brows half as far,
    and the step says so in one sentence per channel."""
    new_session(pi, params_study)
    step = run_check(pi, bridge, tmp_path, "half", HALF)
    assert step["status"] == "pass", step
    assert step["figures"]["measured_gain"] == pytest.approx(0.5, abs=0.1)
    assert "gain 0.5 realised on the head turn: the robot's was 0." in step["value"]
    assert "gain 0.5 realised on the brow raise" in step["value"]
    brows = step["figures"]["brows"]
    assert brows["sent"] / brows["captured"] == pytest.approx(0.5, abs=0.1)


@pytest.mark.usefixtures("flow")
def test_a_jittered_delay_is_judged_within_its_range_with_the_wizard_paths_seed(
    app: FastAPI, pi: StaffApi, params_study: int, bridge: Bridge, tmp_path: Path
) -> None:
    wizard, _ = new_session(pi, params_study)
    # With the session: the seed its interaction in that condition will draw with (its id).
    with_session = pi.get(f"/api/booths/{BOOTH}/check?condition=jitter"
                          f"&session_id={wizard.session_id}")  # fmt: skip
    with app.state.sessionmaker() as db:
        first = db.scalars(select(Interaction.id).where(
            Interaction.session_id == wizard.session_id, Interaction.condition == "jitter"
        ).order_by(Interaction.position)).first()  # fmt: skip
    assert first is not None
    assert with_session["copy_params"]["seed"] == first
    # Without it (the booth's latest study): seed 0, said in the words.
    step = run_check(pi, bridge, tmp_path, "jitter", {**JITTER, "seed": 0})
    assert step["status"] == "pass", step
    low, high = 0.5 - check.MAX_DELAY_ERROR_S, 1.5 + check.MAX_DELAY_ERROR_S
    assert low <= step["figures"]["measured_s"] <= high
    assert "allowed 0.50-1.50 s ±250 ms: the delay is drawn" in step["value"]
    assert "0.5-1.5 s late (uniform, redrawn every 10 s)" in step["value"]
    assert "brows" not in step["value"]  # everything is copied: nothing to separate


def test_a_condition_that_is_not_a_copy_of_the_study_is_refused_in_one_sentence(
    pi: StaffApi, params_study: int
) -> None:
    new_session(pi, params_study)
    response = pi.http.get(f"/api/booths/{BOOTH}/check?condition=still")
    assert response.status_code == 422
    assert response.json()["detail"] == ("'still' is not a copy condition of this study (its "
                                         "copy conditions: head_only, jitter, half).")  # fmt: skip


def judged(params: dict[str, Any], measured: float | None,
           brows: dict[str, float] | None = None, gain: float = 1.0) -> dict[str, Any]:  # fmt: skip
    probe = None if measured is None else {"delay_s": measured, "correlation": 0.95,
                                           "gain": gain}  # fmt: skip
    beat = {"behaviour": "copy", "movement_delay": probe, "movement_brows": brows}
    movement = check.Movement(check_copy.delay_range(params)[0], "c", copy=beat, params=params,
                              words="w")  # fmt: skip
    return check.copies({"input_fps": 60.0}, movement)


@pytest.mark.parametrize(
    ("params", "measured", "brows", "status", "why"),
    [({"channels": "head"}, 4.1, {"captured": 0.5, "sent": 0.4}, "fail",
      "the brows were copied"),
     ({"channels": "face", "delay": 1.0}, None, {"captured": 0.5, "sent": 0.4}, "pass",
      "does not copy the head turn"),
     ({"channels": "face", "delay": 1.0}, None, None, "warn", "delay is not judged"),
     ({"channels": ["head", "brows"]}, 4.0, {"captured": 0.5, "sent": 0.4}, "pass", "4.00 s"),
     ({"delay": {"uniform": [0.5, 1.5]}}, 2.0, None, "fail", "allowed 0.50-1.50 s"),
     ({"delay": {"normal": {"mean": 2.0, "sd": 0.5}}}, 3.2, None, "pass", "0.50-3.50 s"),
     ({"coexpress": True}, 0.05, None, "pass", "+50 ms"),
     ({"coexpress": True}, 0.4, None, "fail", "+400 ms"),
     ({"intermittent": {"rate_per_s": 0.2, "bout_s": 3.0, "rest": "neutral"}}, None, None,
      "warn", "no copied bout was measured"),
     ({"only": ["shakes"], "delay": 1.0}, 1.1, None, "pass",
      "copies only head shakes (yaw >= 10 deg)"),
     ({"only": ["nods"]}, None, None, "warn", "does not copy the head turn")],
)  # fmt: skip
def test_what_each_parameter_lets_the_check_judge(
    params: dict[str, Any], measured: float | None, brows: dict[str, float] | None,
    status: str, why: str,
) -> None:  # fmt: skip
    result = judged(params, measured, brows)
    assert result["status"] == status, result
    assert why in result["value"], result["value"]


@pytest.mark.parametrize(
    ("params", "gain", "brows", "status", "why"),
    [({"delay": 1.0}, 1.05, None, "pass",
      "gain 1 realised on the head turn: the robot's was 1.05 times the participant's (allowed "
      "0.80-1.20)"),
     ({"delay": 1.0}, 0.5, None, "fail",
      "gain NOT realised on the head turn: the robot's was 0.50 times the participant's, the "
      "condition's gain is 1 (allowed 0.80-1.20)"),
     ({"delay": 1.0, "gain": 2.0}, 1.0, None, "fail", "the condition's gain is 2"),
     ({"delay": 1.0, "gain": {"head": 0.5, "HeadYaw": 1.5}}, 1.5, None, "pass",
      "gain 1.5 realised on the head turn"),
     ({"delay": 1.0, "gain": {"brows": 0.5}}, 1.0, {"captured": 0.6, "sent": 0.3}, "pass",
      "gain 0.5 realised on the brow raise: the robot's was 0.50 times the participant's"),
     ({"delay": 1.0, "gain": {"brows": 0.5}}, 1.0, {"captured": 0.6, "sent": 0.6}, "fail",
      "gain NOT realised on the brow raise"),
     ({"delay": 1.0, "gain": 2.0}, 2.0, {"captured": 0.6, "sent": 0.9}, "pass",
      "on the head turn"),  # 0.6 x 2 passes the blendshapes' 1: brows not judged on it
     ({"channels": "face", "delay": 1.0, "gain": 0.5}, 1.0, {"captured": 0.6, "sent": 0.6},
      "fail", "gain NOT realised on the brow raise")],
)  # fmt: skip
def test_the_gain_is_judged_on_the_head_turn_and_the_brows(
    params: dict[str, Any], gain: float, brows: dict[str, float] | None, status: str, why: str
) -> None:
    result = judged(params, 1.0, brows, gain=gain)
    assert result["status"] == status, result
    assert why in result["value"], result["value"]
    if brows and brows["captured"] * check_copy.gain_of(params, "browInnerUp") > 1:
        assert "brow raise" not in result["value"]


@pytest.mark.parametrize(
    ("flip", "mirrored", "status"),
    [(True, True, "pass"), (False, True, "fail"), (True, False, "fail")],
)
def test_a_condition_mirroring_unlike_the_booth_is_judged_on_the_negated_turn(
    flip: bool, mirrored: bool, status: str
) -> None:
    """A condition whose ``mirror`` differs from the booth's sends the yaw negated: the probe
    matches it as ``mirrored``, which must agree with the condition."""
    beat = {"behaviour": "copy", "movement_delay": {"delay_s": 1.0, "correlation": -0.97,
                                                     "mirrored": mirrored}}  # fmt: skip
    movement = check.Movement(1.0, "c", copy=beat, params={"delay": 1.0, "mirror": False},
                              words="w", flip=flip)  # fmt: skip
    result = check.copies({"input_fps": 60.0}, movement)
    assert result["status"] == status, result
    assert ("wrong way" in result["value"]) == (status == "fail")
