from __future__ import annotations

import random

from fastapi.testclient import TestClient
from sqlalchemy import Engine

from tests.support.bots import run_session, staff_api, study_with_plan


def test_a_whole_session_runs_to_complete(client: TestClient, engine: Engine) -> None:
    pi = staff_api(client, engine, "pi")
    study_id = study_with_plan(pi)
    result = run_session(pi, client, study_id, random.Random(1))
    assert result.snapshot["state"] == "complete"
    assert [len(d) for d in result.decisions] == [3, 3, 3]
