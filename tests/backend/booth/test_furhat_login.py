"""A Furhat that refuses the worker's login, end to end through a real bridge and worker:
the timeline gets ``robot.auth_refused``, the wizard's health strip a red *Robot* chip with
the reason, and the driver tries again only when the wizard asks (the peer answers as
Furhat's own client expects: ``response.auth`` with ``access``)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from chameleons.backend.bridge import Bridge
from chameleons.backend.wizard import worker_link
from chameleons.backend.wizard.health import HealthTracker
from tests.backend.booth.conftest import (
    BOOTH,
    new_session,
    running_worker,
    until,
    wait_for_event,
    worker_config,
)
from tests.support.bots import StaffApi
from tests.worker.furhat_peer import FurhatPeer


def _robot_chip(bridge: Bridge) -> dict[str, Any]:
    telemetry, age = worker_link.latest_telemetry(bridge, BOOTH)
    snapshot = HealthTracker().snapshot(BOOTH, telemetry, age)
    return next(c for c in snapshot["checks"] if c["id"] == "robot")


@pytest.mark.usefixtures("flow")
def test_a_refused_login_is_logged_shown_red_and_retried_on_the_wizards_request(
    pi: StaffApi, study_id: int, bridge: Bridge, tmp_path: Path
) -> None:
    wizard, _ = new_session(pi, study_id)
    wizard.start()
    with FurhatPeer(access=False) as peer:
        config = worker_config(bridge, tmp_path, driver="furhat", robot_url=peer.url,
                               robot_key="wrong")  # fmt: skip
        with running_worker(bridge, config):
            event = wait_for_event(wizard, "robot.auth_refused")
            chip = until(lambda: (c := _robot_chip(bridge))["value"].startswith("login") and c,
                         what="the robot chip's reason")  # fmt: skip
            assert peer.connections == 1
            peer.access = True
            answer = pi.post(f"/api/wizard/sessions/{wizard.session_id}/robot/retry")
            wait_for_event(wizard, "robot.connected")
            retried = wait_for_event(wizard, "robot.retry_requested")
        # The worker's stop is logged too; wait for it, so no write is left for the teardown.
        wait_for_event(wizard, "robot.disconnected")
    assert "refused" in event["payload"]["reason"]
    assert chip["ok"] is False
    assert chip["level"] == "alarm"
    assert str(chip["value"]).startswith("login refused: the robot refused the login")
    assert answer["sent"] is True
    assert retried["payload"]["booth"] == BOOTH
    assert peer.connections == 2
