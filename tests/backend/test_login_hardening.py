"""Passwords: minimum length, common-password list, not like the user name. Lock-out per
username and source address with backoff, so nobody can keep the PI locked out."""

from __future__ import annotations

import gzip
import secrets
import subprocess
import sys
from pathlib import Path

import pytest
from fastapi import FastAPI
from fastapi.testclient import TestClient
from pydantic import ValidationError
from sqlalchemy import Engine

from chameleons.backend.auth import passwords as passwords_module
from chameleons.backend.auth.passwords import password_problem
from chameleons.backend.auth.schemas import StaffUserCreate
from chameleons.backend.auth.throttle import (
    ADDRESS_FACTOR,
    MAX_LOCKOUT_SECONDS,
    SWEEP_SECONDS,
    LoginThrottle,
)
from tests.backend.test_auth import add_user, login

DJANGO_LIST = Path(passwords_module.__file__).with_name("django_common_passwords.txt.gz")


@pytest.mark.parametrize(
    ("password", "why"),
    [
        ("Password1", "too common"),
        ("qwertyuiop", "too common"),
        ("83920174652", "only digits"),
        ("aaaaaaaaaaaa", "different characters"),
        ("maryjones1", "similar to the user name"),
    ],
)
def test_guessable_passwords_are_refused_with_a_reason(password: str, why: str) -> None:
    assert why in (password_problem(password, "maryjones") or "")
    with pytest.raises(ValidationError):
        StaffUserCreate(username="maryjones", password=password, role="wizard")


def test_short_passwords_are_refused_and_good_ones_pass() -> None:
    with pytest.raises(ValidationError):
        StaffUserCreate(username="mary", password="x7#k", role="pi")
    assert password_problem("tall green ladder", "mary") is None
    StaffUserCreate(username="mary", password="tall green ladder", role="pi")
    strong = secrets.token_urlsafe(12)
    assert password_problem(strong, "mary") is None
    StaffUserCreate(username="mary", password=strong, role="pi")


@pytest.mark.parametrize("password", ["dragon123", "michael1", "Superman1", "iloveyou2"])
def test_passwords_on_djangos_common_list_are_refused(password: str) -> None:
    with gzip.open(DJANGO_LIST, "rt", encoding="utf-8") as listing:
        assert password.lower() in {line.strip() for line in listing}  # the list has it
    assert "too common" in (password_problem(password, "mary") or "")
    assert "too common" in (password_problem(f" {password.upper()} ", "mary") or "")


def test_the_common_list_is_djangos_whole_list_and_read_only_when_needed() -> None:
    loaded = subprocess.run(
        [
            sys.executable,
            "-c",
            "from chameleons.backend.auth import passwords as p\n"
            "before = p._common.cache_info().currsize\n"
            "print(before, len(p._common()))",
        ],
        capture_output=True,
        text=True,
        check=True,
    )
    before, size = map(int, loaded.stdout.split())
    assert before == 0  # importing the module did not read the list
    assert size >= 19_000
    notice = DJANGO_LIST.with_name("django_common_passwords_LICENSE.txt").read_text()
    assert "Django Software Foundation" in notice


class Clock:
    def __init__(self) -> None:
        self.now = 1000.0

    def __call__(self) -> float:
        return self.now


def test_lockout_doubles_with_each_further_failure() -> None:
    clock = Clock()
    throttle = LoginThrottle(max_failures=3, lockout_seconds=30, clock=clock)
    keys = LoginThrottle.keys("pia", "10.0.0.5")
    for _ in range(3):
        assert throttle.retry_after(*keys) == 0
        throttle.record_failure(*keys)
    assert throttle.retry_after(*keys) == 30
    clock.now += 31
    assert throttle.retry_after(*keys) == 0
    throttle.record_failure(*keys)  # one more after the lock-out: twice as long
    assert throttle.retry_after(*keys) == 60
    clock.now += 61
    throttle.reset(*keys)  # a success forgives
    throttle.record_failure(*keys)
    assert throttle.retry_after(*keys) == 0


def test_failures_from_one_address_do_not_lock_the_user_out_elsewhere() -> None:
    throttle = LoginThrottle(max_failures=3, lockout_seconds=30, clock=Clock())
    attacker = LoginThrottle.keys("pia", "203.0.113.9")
    for _ in range(50):
        throttle.record_failure(*attacker)
    assert throttle.retry_after(*attacker) > 0
    assert throttle.retry_after(*LoginThrottle.keys("pia", "10.0.0.5")) == 0


def test_an_address_spraying_many_names_is_locked_too() -> None:
    throttle = LoginThrottle(max_failures=3, lockout_seconds=30, clock=Clock())
    for n in range(3 * ADDRESS_FACTOR):
        keys = LoginThrottle.keys(f"user{n}", "203.0.113.9")
        assert throttle.retry_after(*keys) == 0
        throttle.record_failure(*keys)
    assert throttle.retry_after(*LoginThrottle.keys("someone", "203.0.113.9")) > 0


def test_records_without_effect_are_swept_so_memory_stays_bounded() -> None:
    clock = Clock()
    throttle = LoginThrottle(max_failures=3, lockout_seconds=30, clock=clock)
    for k in range(1000):  # names and addresses that never come back
        throttle.record_failure(*LoginThrottle.keys(f"user{k}", f"10.0.{k // 256}.{k % 256}"))
    assert len(throttle) == 2000
    locked = LoginThrottle.keys("pia", "10.9.9.9")
    for _ in range(4):
        throttle.record_failure(*locked)
    clock.now += MAX_LOCKOUT_SECONDS + SWEEP_SECONDS + 1  # longer than any lock-out
    throttle.record_failure(*LoginThrottle.keys("new", "10.8.8.8"))
    assert len(throttle) == 2  # only the new failure's records are left


def test_above_the_cap_the_oldest_records_go_and_recent_lockouts_hold() -> None:
    clock = Clock()
    throttle = LoginThrottle(max_failures=3, lockout_seconds=30, clock=clock, max_records=100)
    for k in range(500):  # many addresses within one lock-out
        clock.now += 0.01
        throttle.record_failure(*LoginThrottle.keys("pia", f"10.1.{k // 256}.{k % 256}"))
        assert len(throttle) <= 100
    recent = LoginThrottle.keys("pia", "10.7.7.7")
    for _ in range(3):
        throttle.record_failure(*recent)
    assert throttle.retry_after(*recent) > 0  # the newest lock-out is kept


def test_the_pi_logs_in_while_a_stranger_fails_on_her_name(app: FastAPI, engine: Engine) -> None:
    add_user(engine, "pia", "tall green ladder", "pi")
    with TestClient(app, client=("203.0.113.9", 4000)) as stranger:
        for _ in range(10):
            login(stranger, "pia", "wrong guess!")
        assert login(stranger, "pia", "tall green ladder").status_code == 429  # type: ignore[attr-defined]
    with TestClient(app, client=("10.0.0.5", 4000)) as lab:
        assert login(lab, "pia", "tall green ladder").status_code == 303  # type: ignore[attr-defined]
