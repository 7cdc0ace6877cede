"""The analysis groups by condition name and also says what the robot did in each condition,
from the parameters recorded per interaction (issue 31): where a condition's parameters
varied within the study, and a jittered delay's distribution (its realised delays are not
recorded). On the PI's page, its API and ``chameleons analyze``."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from fastapi.testclient import TestClient
from sqlalchemy import Engine, select
from sqlalchemy.orm import Session as DbSession

from chameleons.backend.db import build_sessionmaker, session_scope
from chameleons.backend.events import repository as events
from chameleons.backend.export.columns import interactions_table, scores_table
from chameleons.backend.export.copy_realised import COPY_DRAW
from chameleons.backend.export.frames import records, table_frame
from chameleons.backend.export.rows import interaction_rows
from chameleons.backend.export.scoring import score_rows
from chameleons.backend.models import Interaction, Study
from chameleons.cli.analyze_command import analysis_output
from chameleons.experiment.stats.measures import study_measures
from chameleons.experiment.stats.robot_behaviour import robot_behaviour, worth_reporting
from chameleons.experiment.study import study_from_config
from tests.backend.analysis.test_analysis import _client_with_data

FIXED = ({"delay": 4.0}, "copies everything, 4 s late, mirror image")
JITTER_WORDS = "copies everything, 0.5-1.5 s late (uniform, redrawn every 10 s), mirror image"
JITTER = ({"delay": {"uniform": [0.5, 1.5]}}, JITTER_WORDS)


def test_one_parameter_set_per_condition_is_not_worth_a_section_but_a_jitter_is() -> None:
    rows = [{"condition": "copy", "participant": p, "behaviour_params": json.dumps(
        {**JITTER[0], "seed": i}), "behaviour_words": f"{JITTER[1]}, seed {i}"}
        for i, p in enumerate(["P1", "P2", "P3"])]  # fmt: skip
    rows.append({"condition": "still", "participant": "P1", "behaviour_params": "{}",
                 "behaviour_words": "holds still (neutral face)"})  # fmt: skip
    summary = robot_behaviour(rows)
    copy = next(c for c in summary if c.condition == "copy")
    assert not copy.varied  # the per-interaction seed is no variation
    assert [(v.words, v.interactions) for v in copy.variants] == [(JITTER[1], 3)]
    assert copy.variants[0].delay_mean_s == 1.0
    assert copy.variants[0].delay_sd_s == pytest.approx(1 / math.sqrt(12))
    assert worth_reporting(summary)
    assert not worth_reporting(robot_behaviour(rows[3:]))
    assert [c.condition for c in robot_behaviour(rows, participants=["P9"])] == []


def vary_copy(engine: Engine) -> int:
    """The study file changed between participants: the first half's copy ran 4 s late,
    the rest jittered 0.5-1.5 s (with each interaction's own seed)."""
    with session_scope(build_sessionmaker(engine)) as db:
        copies = db.scalars(select(Interaction).where(Interaction.condition == "copy")
                            .order_by(Interaction.id)).all()  # fmt: skip
        for k, interaction in enumerate(copies):
            params, words = FIXED if k < len(copies) // 2 else JITTER
            seeded = {**params, "seed": interaction.id} if "uniform" in str(params) else params
            interaction.behaviour_params = dict(seeded)
            interaction.behaviour_words = words + (
                f", seed {interaction.id}" if seeded is not params else "")  # fmt: skip
        return len(copies)


def test_the_page_its_api_and_the_cli_report_a_condition_whose_parameters_varied(
    client: TestClient, engine: Engine
) -> None:
    _client_with_data(client, engine)
    total = vary_copy(engine)
    page = client.get("/pi/analysis")
    assert page.status_code == 200
    assert 'id="robot-behaviour"' in page.text
    assert "(parameters varied within the study)" in page.text
    assert "1.00 ± 0.29 s" in page.text
    assert "0.5-1.5 s late (uniform, redrawn every 10 s), mirror image</td>" in page.text
    api = client.get("/api/pi/analysis").json()["robot_behaviour"]
    copy = next(c for c in api if c["condition"] == "copy")
    assert copy["varied"] is True
    assert sorted(v["interactions"] for v in copy["variants"]) == sorted(
        [total // 2, total - total // 2])  # fmt: skip
    # chameleons analyze: the same rows (the database's, as the CLI reads them).
    with session_scope(build_sessionmaker(engine)) as db:
        study = db.scalars(select(Study)).one()
        spec = study_from_config(study.config)
        scores = records(table_frame(scores_table(spec), score_rows(db, study, spec, False)))
        interactions = records(table_frame(interactions_table(spec),
                                           interaction_rows(db, study, spec, False)))  # fmt: skip
    text = analysis_output(scores, study=study_measures(spec), bootstrap=0, models=False,
                           interactions=interactions)  # fmt: skip
    assert "Robot behaviour per condition (recorded per interaction):" in text
    assert "(parameters varied within the study):" in text
    assert (f"    {total - total // 2} interactions: {JITTER[1]}; delay distribution mean "
            "1.00 s, SD 0.29 s (no realised delays reported)") in text  # fmt: skip
    data = json.loads(analysis_output(scores, "json", study=study_measures(spec), bootstrap=0,
                                      models=False, interactions=interactions))  # fmt: skip
    assert next(c for c in data["robot_behaviour"] if c["condition"] == "copy")["varied"]


def draw(db: DbSession, interaction: Interaction, payload: dict[str, object]) -> None:
    """A copy_draw event as the booth flow logs it from the worker's report."""
    events.record(db, COPY_DRAW, source="bridge", session_id=interaction.session_id,
                  interaction_id=interaction.id, payload={"booth": "b", **payload})  # fmt: skip


def test_the_realised_draws_reach_the_export_the_page_its_api_and_the_cli(
    client: TestClient, engine: Engine
) -> None:
    """The worker's copy_draw events, logged per interaction: each jittered interaction's
    delays summarised in interactions.csv, pooled per condition in the analysis; bouts as
    the share of time copying and bouts per interaction."""
    _client_with_data(client, engine)
    vary_copy(engine)
    drawn: list[float] = []
    with session_scope(build_sessionmaker(engine)) as db:
        jittered = [i for i in db.scalars(select(Interaction).order_by(Interaction.id))
                    if "uniform" in json.dumps(i.behaviour_params)]  # fmt: skip
        first_id = jittered[0].id
        for k, interaction in enumerate(jittered):
            delays = [0.6 + 0.1 * k, 1.0, 1.3 - 0.05 * k]
            drawn += delays
            for block, delay in enumerate(delays):
                draw(db, interaction, {"block": block, "delay_s": delay})
        still = db.scalars(select(Interaction).where(Interaction.condition != "copy")).first()
        assert still is not None
        still.behaviour_params = {"delay": 0.5, "intermittent": {"rate_per_s": 0.5, "bout_s": 2}}
        still.behaviour_words = "copies everything, 0.5 s late, in 2 s bouts at 0.5/s"
        for bout, rest in enumerate([1.0, 3.0]):
            draw(db, still, {"bout": bout, "delay_s": 0.5, "bout_s": 2.0, "rest_s": rest})
        bout_words = still.behaviour_words
        study = db.scalars(select(Study)).one()
        spec = study_from_config(study.config)
        rows = list(interaction_rows(db, study, spec, False))
        scores = records(table_frame(scores_table(spec), score_rows(db, study, spec, False)))
        interactions = records(table_frame(interactions_table(spec), rows))
    params = {r["session"] * 100 + r["position"]: json.loads(r["behaviour_params"] or "{}")
              for r in rows}  # fmt: skip
    first = next(
        r for r in rows if params[r["session"] * 100 + r["position"]].get("seed") == first_id
    )
    assert first["delay_draws"] == 3
    assert first["realised_delay_mean_s"] == pytest.approx(np.mean([0.6, 1.0, 1.3]), abs=1e-4)
    assert first["realised_delay_sd_s"] == pytest.approx(np.std([0.6, 1.0, 1.3], ddof=1),
                                                         abs=1e-4)  # fmt: skip
    assert first["copy_bouts"] is None
    fixed = [r for r in rows if params[r["session"] * 100 + r["position"]] == FIXED[0]]
    assert fixed
    assert all(r["delay_draws"] is None for r in fixed)
    bouts = next(r for r in rows if r["behaviour_words"] == bout_words)
    assert (bouts["copy_bouts"], bouts["copy_fraction"]) == (2, pytest.approx(4 / 8))
    assert bouts["delay_draws"] == 2
    assert bouts["realised_delay_sd_s"] == 0.0
    expected = (f"realised delay mean {np.mean(drawn):.2f} s, SD {np.std(drawn, ddof=1):.2f} s "
                f"({len(drawn)} draws)")  # fmt: skip
    page = client.get("/pi/analysis").text
    assert expected in page
    assert "copying 50% of the time, 2.0 bouts per interaction" in page
    api = client.get("/api/pi/analysis").json()["robot_behaviour"]
    variant = next(v for c in api if c["condition"] == "copy" for v in c["variants"]
                   if v["realised"])  # fmt: skip
    assert variant["realised"]["draws"] == len(drawn)
    assert variant["realised"]["delay_mean_s"] == pytest.approx(np.mean(drawn), abs=1e-3)
    assert variant["realised"]["delay_sd_s"] == pytest.approx(np.std(drawn, ddof=1), abs=1e-3)
    text = analysis_output(scores, study=study_measures(spec), bootstrap=0, models=False,
                           interactions=interactions)  # fmt: skip
    assert f"{JITTER[1]}; delay distribution mean 1.00 s, SD 0.29 s; {expected}" in text
