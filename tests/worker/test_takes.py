"""Live Link Face take CSVs: mapped by header name, timed by timecode."""

from __future__ import annotations

import random
from pathlib import Path

import numpy as np
import pytest

from chameleons.worker.frames import BLENDSHAPE_INDEX
from chameleons.worker.takes import TakeError, parse_timecode, read_take

# The column order of a real take (protocols.md 2b): differs from the UDP order at the jaw
# (JawForward, JawRight, JawLeft, JawOpen) and the mouth (MouthPucker, MouthRight, MouthLeft).
TAKE_SHAPES = [
    *("EyeBlinkLeft", "EyeLookDownLeft", "EyeLookInLeft", "EyeLookOutLeft", "EyeLookUpLeft"),
    *("EyeSquintLeft", "EyeWideLeft", "EyeBlinkRight", "EyeLookDownRight", "EyeLookInRight"),
    *("EyeLookOutRight", "EyeLookUpRight", "EyeSquintRight", "EyeWideRight"),
    *("JawForward", "JawRight", "JawLeft", "JawOpen", "MouthClose", "MouthFunnel"),
    *("MouthPucker", "MouthRight", "MouthLeft", "MouthSmileLeft", "MouthSmileRight"),
    *("MouthFrownLeft", "MouthFrownRight", "MouthDimpleLeft", "MouthDimpleRight"),
    *("MouthStretchLeft", "MouthStretchRight", "MouthRollLower", "MouthRollUpper"),
    *("MouthShrugLower", "MouthShrugUpper", "MouthPressLeft", "MouthPressRight"),
    *("MouthLowerDownLeft", "MouthLowerDownRight", "MouthUpperUpLeft", "MouthUpperUpRight"),
    *("BrowDownLeft", "BrowDownRight", "BrowInnerUp", "BrowOuterUpLeft", "BrowOuterUpRight"),
    *("CheekPuff", "CheekSquintLeft", "CheekSquintRight", "NoseSneerLeft", "NoseSneerRight"),
    "TongueOut",
]
ROTATIONS = [
    *("HeadYaw", "HeadPitch", "HeadRoll", "LeftEyeYaw", "LeftEyePitch", "LeftEyeRoll"),
    *("RightEyeYaw", "RightEyePitch", "RightEyeRoll"),
]
HEADER = ["Timecode", "BlendShapeCount", *TAKE_SHAPES, *ROTATIONS]
assert len(HEADER) == 63


def timecode(frame: int, fraction: str = "000", start: tuple[int, int, int] = (14, 3, 59)) -> str:
    h, m, s = start
    total = ((h * 60 + m) * 60 + s) * 60 + frame
    hh, mm, ss, ff = total // 216000, total // 3600 % 60, total // 60 % 60, total % 60
    return f"{hh:02d}:{mm:02d}:{ss:02d}:{ff:02d}.{fraction}"


def row(tc: str, values: dict[str, float | str]) -> list[str]:
    return [tc, "61"] + [str(values.get(name, 0.0)) for name in HEADER[2:]]


def write(path: Path, header: list[str], rows: list[list[str]]) -> Path:
    path.write_text("\n".join(",".join(r) for r in [header, *rows]) + "\n", encoding="utf-8")
    return path


def test_reads_a_take_by_header_name(tmp_path: Path) -> None:
    rows = [
        row(
            timecode(0),
            {"JawRight": 0.25, "MouthPucker": 0.5, "MouthLeft": 0.125, "HeadYaw": 0.7853982},
        ),
        row(timecode(1, "500"), {"JawOpen": 0.75, "TongueOut": 1.5, "BrowInnerUp": -0.001}),
        row(timecode(3), {"LeftEyePitch": -0.1570796, "HeadRoll": -0.3141593}),
    ]
    take = read_take(write(tmp_path / "take.csv", HEADER, rows))
    assert len(take) == 3
    np.testing.assert_allclose(take.times, [0.0, 1.5 / 60, 3 / 60], atol=1e-9)
    assert take.times.dtype == np.float64
    assert take.blendshapes.dtype == np.float32
    assert take.blendshapes.shape == (3, 52)
    b = take.blendshapes
    assert b[0, BLENDSHAPE_INDEX["jawRight"]] == 0.25
    assert b[0, BLENDSHAPE_INDEX["jawLeft"]] == 0.0
    assert b[0, BLENDSHAPE_INDEX["mouthPucker"]] == 0.5
    assert b[0, BLENDSHAPE_INDEX["mouthLeft"]] == 0.125
    assert b[1, BLENDSHAPE_INDEX["jawOpen"]] == 0.75
    assert b[1, BLENDSHAPE_INDEX["tongueOut"]] == 1.0  # clamped
    assert b[1, BLENDSHAPE_INDEX["browInnerUp"]] == 0.0
    np.testing.assert_allclose(take.head[0], [45.0, 0, 0], atol=1e-4)  # radians, the default
    np.testing.assert_allclose(take.head[2], [0, 0, -18.0], atol=1e-4)
    np.testing.assert_allclose(take.eyes[2], [0, -9.0, 0, 0, 0, 0], atol=1e-4)
    assert take.duration == pytest.approx(0.05)
    frame = take.frame(1, now=7.0)
    assert frame.capture_time == 7.0
    assert frame.blendshapes[BLENDSHAPE_INDEX["jawOpen"]] == 0.75


def test_reordered_columns_give_the_same_take(tmp_path: Path) -> None:
    rng = random.Random(4)
    rows = [
        row(timecode(2 * i), {n: round(rng.random(), 3) for n in HEADER[2:]}) for i in range(20)
    ]
    plain = read_take(write(tmp_path / "a.csv", HEADER, rows))
    order = list(range(len(HEADER)))
    rng.shuffle(order)
    shuffled = read_take(
        write(tmp_path / "b.csv", [HEADER[i] for i in order], [[r[i] for i in order] for r in rows])
    )
    np.testing.assert_array_equal(plain.blendshapes, shuffled.blendshapes)
    np.testing.assert_array_equal(plain.head, shuffled.head)
    np.testing.assert_array_equal(plain.eyes, shuffled.eyes)
    np.testing.assert_array_equal(plain.times, shuffled.times)


@pytest.mark.parametrize("step", [1, 2])
def test_time_from_timecode_at_60_and_30_hz(tmp_path: Path, step: int) -> None:
    rows = [row(timecode(step * i), {}) for i in range(130)]  # crosses second boundaries
    take = read_take(write(tmp_path / "t.csv", HEADER, rows))
    np.testing.assert_allclose(np.diff(take.times), step / 60, atol=1e-9)
    assert take.times[0] == 0.0


def test_time_is_not_the_row_index(tmp_path: Path) -> None:
    frames = [0, 1, 3, 4, 8]  # dropped frames in the recording
    take = read_take(write(tmp_path / "t.csv", HEADER, [row(timecode(f), {}) for f in frames]))
    np.testing.assert_allclose(take.times * 60, frames, atol=1e-9)


def test_take_over_midnight(tmp_path: Path) -> None:
    rows = [row("23:59:59:59.000", {}), row("00:00:00:01.000", {})]
    take = read_take(write(tmp_path / "t.csv", HEADER, rows))
    np.testing.assert_allclose(take.times, [0, 2 / 60], atol=1e-9)


def test_missing_rotation_and_tongue_columns_read_as_zero(tmp_path: Path) -> None:
    header = [h for h in HEADER if h not in ROTATIONS and h != "TongueOut"]
    rows = [[timecode(0), "61", *["0.5"] * (len(header) - 2)]]
    take = read_take(write(tmp_path / "t.csv", [*header, "Extra"], [[*r, "x"] for r in rows]))
    assert take.blendshapes[0, BLENDSHAPE_INDEX["tongueOut"]] == 0.0
    assert take.blendshapes[0, 0] == 0.5
    assert not take.head.any()


def test_bom_and_blank_lines(tmp_path: Path) -> None:
    path = write(tmp_path / "t.csv", HEADER, [row(timecode(0), {}), [""], row(timecode(1), {})])
    path.write_bytes(b"\xef\xbb\xbf" + path.read_bytes())
    assert len(read_take(path)) == 2


def broken(tmp_path: Path, header: list[str], rows: list[list[str]]) -> str:
    path = write(tmp_path / "broken.csv", header, rows)
    with pytest.raises(TakeError) as info:
        read_take(path)
    message = str(info.value)
    assert str(path) in message
    return message


def test_broken_takes_name_file_and_line(tmp_path: Path) -> None:
    good = [row(timecode(i), {}) for i in range(5)]
    bad_value = [*good[:3], row(timecode(3), {"JawOpen": "abc"}), good[4]]
    assert "broken.csv:5: column 'JawOpen': 'abc' is not a number" in broken(
        tmp_path, HEADER, bad_value
    )
    assert "broken.csv:3:" in broken(tmp_path, HEADER, [good[0], good[1][:-3]])
    assert "does not advance" in broken(tmp_path, HEADER, [good[1], good[0]])
    assert "broken.csv:2: timecode" in broken(tmp_path, HEADER, [["12:00", *good[0][1:]]])
    assert "out of range" in broken(tmp_path, HEADER, [["12:00:00:60.000", *good[0][1:]]])
    assert "not finite" in broken(tmp_path, HEADER, [row(timecode(0), {"HeadYaw": "nan"})])
    assert "no data rows" in broken(tmp_path, HEADER, [])
    missing = broken(tmp_path, [h for h in HEADER if h != "JawOpen"], [])
    assert "broken.csv:1: missing blendshape columns: jawOpen" in missing
    assert "no Timecode" in broken(tmp_path, HEADER[1:], [])
    assert "appears twice" in broken(tmp_path, [*HEADER, "eyeBlink_L"], [])


def test_unreadable_files(tmp_path: Path) -> None:
    with pytest.raises(TakeError, match="cannot read"):
        read_take(tmp_path / "absent.csv")
    empty = tmp_path / "empty.csv"
    empty.write_text("")
    with pytest.raises(TakeError, match=r"empty.csv:1: empty file"):
        read_take(empty)
    binary = tmp_path / "video.mov"
    binary.write_bytes(b"\x00\x00\x00\x14ftypqt  \xff\xfe\x80")
    with pytest.raises(TakeError, match=r"video\.mov"):
        read_take(binary)


@pytest.mark.parametrize(
    ("text", "seconds"),
    [("00:00:01:00.000", 1.0), ("00:00:00:30.500", 30.5 / 60), ("01:02:03:04", 3723 + 4 / 60),
     ("10:00:00;59.250", 36000 + 59.25 / 60)],
)  # fmt: skip
def test_parse_timecode(text: str, seconds: float) -> None:
    assert parse_timecode(text) == pytest.approx(seconds)


def based_timecode(frame: int, base: int, sep: str = ":") -> str:
    seconds, ff = divmod(frame, base)
    return f"10:00:{seconds:02d}{sep}{ff:02d}.000"


@pytest.mark.parametrize("base", [24, 25, 30, 50, 60])
def test_takes_on_every_timecode_base_are_timed_by_it(tmp_path: Path, base: int) -> None:
    rows = [row(based_timecode(f, base), {}) for f in range(2 * base + 3)]  # past a second
    take = read_take(write(tmp_path / "t.csv", HEADER, rows))
    assert take.timecode_fps == base
    np.testing.assert_allclose(np.diff(take.times), 1 / base, atol=1e-9)
    assert take.duration == pytest.approx((2 * base + 2) / base)


def test_a_drop_frame_take_is_29_97(tmp_path: Path) -> None:
    # 29.97 drop-frame: after 00:00:59;29 comes 00:01:00;02 (0 and 1 are skipped).
    rows = [row("10:00:59;28.000", {}), row("10:00:59;29.000", {}), row("10:01:00;02.000", {})]
    take = read_take(write(tmp_path / "t.csv", HEADER, rows))
    assert take.timecode_fps == pytest.approx(29.97, abs=0.001)
    np.testing.assert_allclose(np.diff(take.times), 1001 / 30000, atol=1e-9)


def test_an_explicit_base_wins_and_a_short_take_keeps_60(tmp_path: Path) -> None:
    rows = [row(based_timecode(f, 30), {}) for f in range(10)]  # less than a second
    path = write(tmp_path / "t.csv", HEADER, rows)
    assert read_take(path).timecode_fps == 60.0
    assert read_take(path, fps=30).timecode_fps == 30.0
    np.testing.assert_allclose(np.diff(read_take(path, fps=30).times), 1 / 30, atol=1e-9)


def test_parse_timecode_at_25_and_drop_frame() -> None:
    assert parse_timecode("00:00:01:12.500", 25) == pytest.approx(1 + 12.5 / 25)
    # 10 minutes of drop-frame is exactly 17982 frames.
    assert parse_timecode("00:10:00;00.000", 30000 / 1001) == pytest.approx(17982 * 1001 / 30000)
    with pytest.raises(ValueError, match="out of range"):
        parse_timecode("00:00:00:25.000", 25)


def test_all_zero_head_columns_are_reported(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    rows = [row(timecode(f), {"JawOpen": 0.5, "LeftEyeYaw": 0.1}) for f in range(5)]
    with caplog.at_level("WARNING", logger="chameleons.worker.takes"):
        take = read_take(write(tmp_path / "off.csv", HEADER, rows))
    assert take.notes == ("head streaming was off in this take (HeadYaw, HeadPitch, HeadRoll "
                          "all zero)",)  # fmt: skip
    assert "off.csv: head streaming was off" in caplog.text
    moving = [row(timecode(f), {"HeadPitch": 0.01 * f}) for f in range(5)]
    assert read_take(write(tmp_path / "on.csv", HEADER, moving)).notes == ()


def test_a_take_replayed_as_a_natural_clip_reads_its_rotations_in_the_workers_unit(
    tmp_path: Path,
) -> None:
    """``natural`` replaying a take CSV honours the worker's livelink_rotation_scale (the
    behaviour context's rotation factor), as the capture does; not the reader's default."""
    from chameleons.worker.behaviours.clips import load_clip
    from chameleons.worker.behaviours.natural import NaturalBehaviour
    from chameleons.worker.behaviours.router import build_context
    from chameleons.worker.ingest.livelink import rotation_factor

    rows = [row(timecode(f), {"HeadYaw": 0.5, "JawOpen": 0.2}) for f in range(5)]
    path = write(tmp_path / "take.csv", HEADER, rows)
    assert load_clip(path).vectors[0, 52] == pytest.approx(0.5 * 180 / np.pi, rel=1e-5)
    assert load_clip(path, rotation_factor=1.0).vectors[0, 52] == pytest.approx(0.5)
    context = build_context(rotation_factor=rotation_factor("degrees/180"))
    natural = NaturalBehaviour.from_params(context, {"path": str(path), "loop": False})
    assert isinstance(natural, NaturalBehaviour)
    assert natural.clip.vectors[0, 52] == pytest.approx(0.5 * 180)
