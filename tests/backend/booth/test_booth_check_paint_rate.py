"""The booth check's Robot step judges how smoothly the display painted during the check
(the median of its page's reports, :meth:`DisplayChannel.paint_rate`), not only that it
plays: a display in a background tab paints a frame or two a second, which passes a
presence check most seconds while the participant sees a face that jumps."""

from __future__ import annotations

from pathlib import Path

import pytest

from chameleons.backend.booth import check

PLAYING = (True, "display open")
DISPLAY_BOOTH = {"driver": "virtual"}
BOTH_ROBOTS = {"driver": "virtual+furhat", "robot_outputs": {"furhat": {"state": "connected"}}}


def on(output: str, words: str) -> dict[str, str | None]:
    return {"renderer": None, "output": output, "words": words, "problem": None}


def test_a_display_painting_under_the_floor_warns_with_the_cause_and_the_fix() -> None:
    warned = check.robot(DISPLAY_BOOTH, PLAYING, paint_fps=1.5)
    assert warned["status"] == "warn"
    assert warned["figures"] == {"display_fps": 1.5}
    assert warned["value"].startswith("display open, but it painted only 2 frames a second")
    assert "full-screen window of its own" in warned["value"]
    assert "background tab" in warned["value"]
    smooth = check.robot(DISPLAY_BOOTH, PLAYING, paint_fps=check.MIN_DISPLAY_FPS)
    assert (smooth["status"], smooth["value"]) == ("pass", "display open")
    assert smooth["figures"] == {"display_fps": check.MIN_DISPLAY_FPS}


def test_the_paint_rate_is_judged_only_when_the_display_is_the_robot_checked() -> None:
    furhat = check.robot(BOTH_ROBOTS, PLAYING, on("furhat", "the Furhat"), paint_fps=1.0)
    assert (furhat["status"], furhat["value"]) == ("pass", "the Furhat: connected")
    assert furhat["figures"] == {}
    display = check.robot(BOTH_ROBOTS, PLAYING, on("display", "the display's 3D head"), 3.0)
    assert display["status"] == "warn"
    assert display["value"].startswith("the display's 3D head: display open, but it painted "
                                       "only 3 frames")  # fmt: skip
    # No report during the check: nothing to judge it by (presence decides, as before).
    assert check.robot(DISPLAY_BOOTH, PLAYING)["status"] == "pass"


@pytest.mark.parametrize("fps", [0.5, 60.0])
def test_a_display_that_does_not_play_fails_whatever_it_painted(fps: float) -> None:
    failed = check.robot(DISPLAY_BOOTH, (False, "robot display not playing"), paint_fps=fps)
    assert (failed["status"], failed["value"]) == ("fail", "robot display not playing")


def test_a_slow_display_warns_but_does_not_fail_the_check(tmp_path: Path) -> None:
    slow, smooth = (check.run(DISPLAY_BOOTH, PLAYING, tmp_path, 0, paint_fps=fps)
                    for fps in (1.0, 60.0))  # fmt: skip
    assert [s["status"] for s in slow["steps"] if s["id"] == "robot"] == ["warn"]
    assert [s["status"] for s in smooth["steps"] if s["id"] == "robot"] == ["pass"]
    # The other steps are judged alike, so the warning alone changes nothing else.
    assert [s for s in slow["steps"] if s["id"] != "robot"] == [
        s for s in smooth["steps"] if s["id"] != "robot"]  # fmt: skip
    assert slow["passed"] == smooth["passed"]
