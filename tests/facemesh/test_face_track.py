"""``chameleons face-track``: real-face videos in four containers -> a Live Link Face take
that ``prompts import`` and the take reader accept; unreadable and face-less videos are
refused in one sentence."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from chameleons.cli.main import cli
from chameleons.worker.take_writer import HEADER, timecode, timecode_base
from chameleons.worker.takes import parse_timecode, read_take
from tests.support.faces import Motion, scene
from tests.support.videos import write_video

RATE = 25
# 0.4 s upright, a roll to +20 degrees over 0.4 s, 0.4 s held, 0.4 s without a face, and
# the face back upright for 0.4 s: 50 frames at 25 fps, 10 of them face-less.
ROLLS = [0.0] * 10 + [2.0 * k for k in range(1, 11)] + [20.0] * 10 + [None] * 10 + [0.0] * 10


def frames() -> list[np.ndarray]:
    return [scene("astronaut", Motion(angle=a or 0.0, face=a is not None)) for a in ROLLS]


@pytest.fixture(scope="module")
def clip_frames() -> list[np.ndarray]:
    return frames()


def track(video: Path, out: Path) -> tuple[int, str]:
    result = CliRunner().invoke(cli, ["face-track", str(video), "--out", str(out)])
    return result.exit_code, result.output


@pytest.mark.slow
@pytest.mark.parametrize("suffix", ["mp4", "webm", "mov", "avi"])
def test_four_containers_become_a_take(tmp_path: Path, clip_frames: list[np.ndarray],
                                       suffix: str) -> None:  # fmt: skip
    video = write_video(tmp_path / f"face.{suffix}", clip_frames, RATE)
    out = tmp_path / "take.csv"
    code, output = track(video, out)
    assert code == 0, output
    with out.open(newline="") as handle:
        rows = list(csv.reader(handle))
    assert tuple(rows[0]) == HEADER
    assert len(HEADER) == 63
    assert len(rows) - 1 == len(ROLLS) - ROLLS.count(None)
    times = [parse_timecode(r[0], timecode_base(RATE)) for r in rows[1:]]
    expected = [k / RATE for k, r in enumerate(ROLLS) if r is not None]
    assert times == pytest.approx(expected, abs=1e-3)  # the face-less stretch left out
    take = read_take(out)  # the take reader (and so prompts import) accepts it
    assert take.timecode_fps == timecode_base(RATE)
    assert take.times == pytest.approx(np.array(expected) - expected[0], abs=1e-3)
    roll = take.head[:, 2]  # degrees, read back from the take's radians
    upright = float(np.median(roll[:8]))
    turned = float(np.median(roll[22:30]))  # frames 22..29 of the take: the held 20 degrees
    assert turned - upright == pytest.approx(20.0, abs=3.0)
    assert np.all(np.abs(np.radians(take.head)) < np.pi)


def test_prompts_import_takes_the_tracked_take_as_a_natural_clip(
    tmp_path: Path, clip_frames: list[np.ndarray]
) -> None:
    video = write_video(tmp_path / "face.mp4", clip_frames[:30], RATE)
    out = tmp_path / "take.csv"
    assert track(video, out)[0] == 0
    actor = tmp_path / "actor"
    actor.mkdir()
    (actor / "actor.yaml").write_text("id: actor\nname: Actor\n", encoding="utf-8")
    result = CliRunner().invoke(cli, ["prompts", "import", str(actor), str(out),
                                      "--natural", "webcam_clip"])  # fmt: skip
    assert result.exit_code == 0, result.output
    assert any(actor.rglob("*webcam_clip*"))


def test_an_unreadable_or_face_less_video_is_refused_in_one_sentence(tmp_path: Path) -> None:
    junk = tmp_path / "junk.mp4"
    junk.write_bytes(b"this is not a video" * 100)
    code, output = track(junk, tmp_path / "a.csv")
    assert code == 1
    assert output.startswith("Error: "), output
    assert output.count("\n") == 1, output
    assert "not a video" in output
    empty = write_video(tmp_path / "empty.avi",
                        [scene("astronaut", Motion(face=False))] * 6, RATE)  # fmt: skip
    code, output = track(empty, tmp_path / "b.csv")
    assert code == 1
    assert output == f"Error: {empty}: no face found in any of its 6 frames; nothing written.\n"
    assert not (tmp_path / "a.csv").exists()
    assert not (tmp_path / "b.csv").exists()


@pytest.mark.parametrize(("seconds", "rate", "text"), [
    (0.0, 30, "00:00:00:00.000"), (1.5, 30, "00:00:01:15.000"), (1 / 15, 15, "00:00:00:01.600"),
    (3661.04, 25, "01:01:01:01.000"), (2 / 29.97, 29.97, "00:00:00:02.002"),
])  # fmt: skip
def test_timecodes_read_back_as_the_video_time(seconds: float, rate: float, text: str) -> None:
    base = timecode_base(rate)
    assert timecode(seconds, base) == text
    assert parse_timecode(text, base) == pytest.approx(seconds, abs=1e-3 / base)
