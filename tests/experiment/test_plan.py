"""The plan's report, row helpers and the ``chameleons plan`` command."""

from __future__ import annotations

import csv
import io
import json
from dataclasses import replace
from pathlib import Path

import pytest
from click.testing import CliRunner

from chameleons.cli.main import cli
from chameleons.experiment.design import (
    PlanError,
    assign_row,
    balance_report,
    next_free_row,
    plan,
    plan_row,
    plan_to_dict,
)
from chameleons.experiment.study import load_default_study
from tests.experiment.study_files import default_document, write_study
from tests.experiment.test_plan_verifier import verify


def test_verifier_catches_a_broken_plan() -> None:
    rows = plan(load_default_study(), 12, 0).rows
    first = rows[0].interactions[0]
    other = next(a for a in ("m1", "m2", "f1", "f2") if a != first.actor)
    broken = [
        replace(rows[0], interactions=[replace(first, actor=other), *rows[0].interactions[1:]])
    ]
    with pytest.raises(AssertionError):
        verify(broken + rows[1:], exact=True)


def test_balance_report_is_exact_for_twelve_and_says_where_it_is_not() -> None:
    study = load_default_study()
    report = plan(study, 12, 1).balance
    assert report.ok
    # Nine showings of five items cannot be exactly even first/last (constraint 8).
    assert all(c.exact for c in report.constraints if c.constraint != 8)
    assert {c.constraint for c in report.constraints} == set(range(9))
    partial = balance_report(study, plan(study, 2, 1).rows)
    carry = next(c for c in partial.constraints if c.id == "carry_over")
    # Two rows of three conditions cannot be even in adjacent pairs once every condition
    # must be within 1 at each position: uneven, but the least uneven possible.
    assert not carry.within_one
    assert carry.status == "minimal"
    assert carry.ok
    assert carry.verdict() == "minimal possible imbalance"
    json.dumps(partial.to_dict())


def test_balance_says_minimal_possible_where_counts_cannot_be_more_even() -> None:
    """N = 100: carry-over 1.33 and condition x scenario 1.00 from their ideals are the
    provable minimum (an integer program over the row kinds), not "UNEVEN"."""
    study = load_default_study()
    report = plan(study, 100, 7).balance
    minimal = {c.id: c for c in report.minimal}
    assert set(minimal) == {"carry_over", "condition_scenario"}
    assert minimal["carry_over"].max_deviation == pytest.approx(4 / 3)
    assert minimal["carry_over"].lower_bound == pytest.approx(4 / 3, abs=1e-6)
    assert report.ok
    assert report.problems() == []
    rows = plan(study, 100, 7).rows
    # The same 100 rows with one row's conditions reversed: no longer the minimum.
    first = rows[0]
    reversed_row = replace(first, interactions=[
        replace(i, condition=first.interactions[-1 - n].condition)
        for n, i in enumerate(first.interactions)
    ])  # fmt: skip
    worse = balance_report(study, [reversed_row, *rows[1:]])
    assert any(c.status == "uneven" for c in worse.constraints)


def test_every_item_first_and_last_cannot_hold_with_six() -> None:
    """N = 6: two scenarios are shown 4 times for their 5 items, so constraint 8 (every
    item at least once first and last) cannot hold, and the report does not say ok."""
    study = load_default_study()
    report = plan(study, 6, 7).balance
    blocked = [c for c in report.constraints if c.status == "cannot hold"]
    assert blocked
    assert all(c.id.startswith("item_at_ends:") for c in blocked)
    assert "shown 4 times for its 5 items" in blocked[0].verdict()
    assert not report.ok
    assert any("not every item can be first and last" in p for p in report.problems())
    assert plan(study, 12, 7).balance.ok
    out = CliRunner().invoke(cli, ["plan", "-n", "6", "--seed", "7"]).stdout
    assert "CANNOT HOLD: with 6 participants, desert-" in out
    assert "Every count is as even" not in out


def test_plan_command_words_the_minimum() -> None:
    out = CliRunner().invoke(cli, ["plan", "-n", "100", "--seed", "7"]).stdout
    assert "carry_over" in out
    assert "UNEVEN" not in out
    assert out.count("minimal possible imbalance") == 3  # two tables and the summary
    assert "Every count is as even as possible with 100 participants" in out


def test_report_counts_what_it_is_given() -> None:
    study = load_default_study()
    rows = plan(study, 12, 1).rows
    report = balance_report(study, [*rows, rows[0]])  # one row used twice
    actor = next(c for c in report.constraints if c.id == "actor")
    assert actor.ideal == 9.75
    assert sorted(actor.counts.values()) == [9, 10, 10, 10]


def test_plan_to_dict_has_the_issue_shape() -> None:
    data = plan_to_dict(plan(load_default_study(), 2, 0))
    first = data["rows"][0]
    assert first["participant"] == 1
    assert list(first["interactions"][0]) == [
        "position", "condition", "actor", "face", "robot_name", "task", "item_set", "item_order"
    ]  # fmt: skip
    assert len(first["interactions"][0]["item_order"]) == 5
    assert data["balance"]["participants"] == 2
    json.dumps(data)


def test_plan_row_is_the_row_of_the_longer_plan() -> None:
    study = load_default_study()
    assert plan_row(study, 4, 17) == plan(study, 20, 4).rows[16]
    with pytest.raises(PlanError):
        plan_row(study, 4, 0)


def test_rows_are_handed_out_lowest_free_first() -> None:
    assert next_free_row([]) == 1
    assert next_free_row({1, 2, 4}) == 3
    taken = set(range(1, 13))
    taken.discard(5)  # the participant of row 5 withdrew
    assert next_free_row(taken) == 5
    assert assign_row(taken, replacing=5) == 5
    assert assign_row(taken | {5}) == 13
    with pytest.raises(PlanError, match="held by another participant"):
        assign_row(taken | {5}, replacing=5)


def run(*args: str) -> tuple[int, str, str]:
    result = CliRunner().invoke(cli, list(args))
    return result.exit_code, result.stdout, result.stderr


def test_plan_command_json() -> None:
    code, out, _ = run("plan", "--participants", "12", "--seed", "3", "--format", "json")
    assert code == 0
    data = json.loads(out)
    assert len(data["rows"]) == 12
    assert data["balance"]["ok"] is True
    assert data["rows"] == plan_to_dict(plan(load_default_study(), 12, 3))["rows"]


def test_plan_command_table_and_csv() -> None:
    code, out, _ = run("plan", "-n", "2")
    assert code == 0
    assert "balance period 12" in out
    assert "condition_position" in out
    code, out, err = run("plan", "-n", "3", "--format", "csv")
    assert code == 0
    lines = list(csv.DictReader(io.StringIO(out)))
    assert len(lines) == 9
    assert len(lines[0]["item_order"].split(";")) == 5
    assert "Balance" in err


def test_plan_command_reports_a_bad_study_readably(tmp_path: Path) -> None:
    document = default_document()
    document["tasks"]["lunar"]["items"][3]["expert_rank"] = 3
    path = write_study(tmp_path, document)
    code, _, err = run("plan", "-n", "4", "--study", str(path))
    assert code == 1
    assert "tasks.lunar.items[3]: expert rank 3 used twice" in err
    assert "Traceback" not in err


def test_plan_command_rejects_bad_arguments() -> None:
    code, _, err = run("plan", "--participants", "0")
    assert code == 2
    assert "participants" in err
    code, _, err = run("plan", "-n", "3", "--study", "/nonexistent/study.yaml")
    assert code == 1
    assert "cannot read the file" in err


def test_a_study_without_task_alternation(tmp_path: Path) -> None:
    document = default_document()
    del document["tasks"]["desert"]
    document["item_sets"].update(first_rank=1, last_rank=15, sets=["a", "b", "c"])
    document["design"]["alternate_tasks"] = False
    code, out, _ = run(
        "plan", "-n", "12", "--format", "json", "--study", str(write_study(tmp_path, document))
    )
    assert code == 0
    data = json.loads(out)
    assert data["balance"]["ok"] is True
    assert {i["task"] for row in data["rows"] for i in row["interactions"]} == {"lunar"}
    assert "task_twice_in_a_row" not in {c["id"] for c in data["balance"]["constraints"]}
