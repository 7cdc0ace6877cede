"""The counted bench (``bench.submission_calls``): both apps' requests are counted, the
client's own calls are not, and the statements are those the apps really run."""

from __future__ import annotations

import threading
from pathlib import Path

from bench import submission_calls
from bench.submission_calls import Counter, count_bare, measure, profiled


def test_both_apps_are_counted_and_compared() -> None:
    result = measure(2, (1, 2))
    bare = result["bare"]
    # The bare app: the submission's and the event's INSERT, then the count and the newest.
    assert bare["statements"] == 4
    assert bare["python_calls"] > 100
    assert bare["c_calls"] > 100
    first, second = (result["positions"][p] for p in ("1", "2"))
    for found in (first, second):
        assert found["real"]["python_calls"] > 100
        assert found["real"]["statements"] >= 4  # the session's load, the ranking, its event
        assert (
            found["ratio"]["python_calls"] == found["real"]["python_calls"] / bare["python_calls"]
        )
    # Interaction 1's suggestions are settled by the time of interaction 2's ranking, and
    # kept (sessions.snapshot): that ranking reads no more than the first one.
    assert second["real"]["statements"] == first["real"]["statements"]
    # The decision: the session and its interactions, the suggestions (read once), the
    # decision's update, the next proposal, two events.
    decision = result["decision"]["real"]
    assert decision["statements"] >= 7
    assert decision["python_calls"] > first["real"]["python_calls"]  # two events, not one
    lines: list[str] = []
    submission_calls.report(result, lines.append)
    assert any(line.startswith("Python calls") for line in lines)
    assert any(line.startswith("A wizard's decision") for line in lines)


def test_the_calling_thread_is_not_counted_and_others_are() -> None:
    counter = Counter()

    def work() -> None:
        sorted(range(10))

    with profiled(counter), counter.counting():
        work()  # this thread: the client's
        thread = threading.Thread(target=work)
        thread.start()
        thread.join()
    assert counter.counts.python_calls >= 1  # ``work`` in the other thread
    assert counter.counts.c_calls >= 1  # its ``sorted``
    alone = Counter()
    with profiled(alone), alone.counting():
        work()
    assert (alone.counts.python_calls, alone.counts.c_calls) == (0, 0)


def test_the_bare_app_is_left_as_it_was(tmp_path: Path) -> None:
    from bench import baseline_app

    before = baseline_app.ENGINE
    count_bare(1, tmp_path)
    assert baseline_app.ENGINE is before
