"""The health checks from the worker's telemetry, and how long each has been failing."""

from __future__ import annotations

from chameleons.backend.wizard.health import HealthTracker, evaluate

# The fields of the worker's heartbeat (chameleons.worker.hub.ControlHub.status).
GOOD = {
    "input_fps": 59.8,
    "tick_rate_hz": 124.9,
    "jitter_ms": {"p50": 0.1, "p99": 0.4, "max": 0.9},
    "robot_connected": True,
    "speaking": False,
}


def test_good_telemetry_passes_every_check() -> None:
    checks = evaluate(GOOD, age=0.5)
    assert all(check.ok for check in checks.values())
    assert checks["tick"].value == "124.9 Hz"
    assert checks["speaking"].value == "quiet"


def test_each_failure_is_its_own_check() -> None:
    bad = {**GOOD, "input_fps": 3.0, "tick_rate_hz": 90.0, "jitter_ms": {"p99": 5.0}}
    bad["robot_connected"] = False
    checks = evaluate(bad, age=0.5)
    failing = sorted(name for name, check in checks.items() if check.ok is False)
    assert failing == ["input", "jitter", "robot", "tick"]


def test_stale_telemetry_means_the_worker_is_gone() -> None:
    checks = evaluate(GOOD, age=4.0)
    assert checks["worker"].ok is False
    assert checks["worker"].value == "silent 4 s"
    assert checks["robot"].ok is None


def test_failing_time_counts_from_the_first_failure_and_resets_on_recovery() -> None:
    tracker = HealthTracker()
    first = tracker.snapshot("b1", None, None, now=100.0)
    later = tracker.snapshot("b1", None, None, now=112.5)
    worker = next(c for c in later["checks"] if c["id"] == "worker")
    assert first["ok"] is False
    assert worker["failing_for"] == 12.5
    recovered = tracker.snapshot("b1", GOOD, 0.2, now=113.0)
    assert recovered["ok"] is True
    again = tracker.snapshot("b1", None, None, now=120.0)
    assert next(c for c in again["checks"] if c["id"] == "worker")["failing_for"] == 0.0


def test_booths_are_tracked_apart() -> None:
    tracker = HealthTracker()
    tracker.snapshot("b1", None, None, now=0.0)
    other = tracker.snapshot("b2", None, None, now=30.0)
    assert next(c for c in other["checks"] if c["id"] == "worker")["failing_for"] == 0.0
