"""The lip-sync CSV loader: tolerant where it can be, clear where it cannot."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from chameleons.worker.lipsync import LIPSYNC_NAMES, LipSync, LipSyncError, load_lipsync


def _write(tmp_path: Path, text: str, encoding: str = "utf-8") -> Path:
    path = tmp_path / "prompt.csv"
    path.write_bytes(text.encode(encoding))
    return path


def test_reads_time_and_blendshape_columns_in_any_spelling(tmp_path: Path) -> None:
    path = _write(tmp_path, "\ufefftime, JawOpen ,MOUTH_SMILE_LEFT,mouthClose_R\r\n"
                            "# comment\r\n0.0,0.1,0.0,0\r\n\r\n0.02, 0.5 ,1.2,0\r\n")  # fmt: skip
    lipsync = load_lipsync(path)
    np.testing.assert_allclose(lipsync.times, [0.0, 0.02])
    assert set(lipsync.channels) == {"jawOpen", "mouthSmileLeft"}
    jaw = LIPSYNC_NAMES.index("jawOpen")
    np.testing.assert_allclose(lipsync.values[:, jaw], [0.1, 0.5])
    assert lipsync.values[1, LIPSYNC_NAMES.index("mouthSmileLeft")] == 1.0  # clamped
    assert lipsync.ignored == ("mouthClose_R",)  # not an ARKit name: listed, not fatal
    assert lipsync.duration == pytest.approx(0.02)


def test_non_mouth_channels_are_ignored(tmp_path: Path) -> None:
    lipsync = load_lipsync(_write(tmp_path, "time,jawOpen,eyeBlinkLeft\n0,0.2,1\n0.1,0.3,1\n"))
    assert lipsync.channels == ("jawOpen",)
    assert lipsync.ignored == ("eyeBlinkLeft",)


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("", "empty file"),
        ("jawOpen,mouthClose\n0.1,0.2\n", "no 'time' column"),
        ("time,jawOpen\n0,0.1\n0.1\n", ":3: 1 cells, header has 2"),
        ("time,jawOpen\n0,wide\n", ":2: jawOpen is not a number: 'wide'"),
        ("time,jawOpen\n0,nan\n", ":2: jawOpen is not finite"),
        ("time,jawOpen\n0.1,0\n0.1,0.2\n", "times must increase"),
        ("time,eyeBlinkLeft\n0,0.1\n", "no mouth or jaw"),
        ("time,jawOpen\n", "no rows"),
    ],
)
def test_problems_are_errors_naming_file_and_line(tmp_path: Path, text: str, message: str) -> None:
    with pytest.raises(LipSyncError, match=message.replace("(", r"\(")) as caught:
        load_lipsync(_write(tmp_path, text))
    assert "prompt.csv" in str(caught.value)


def test_missing_and_undecodable_files(tmp_path: Path) -> None:
    with pytest.raises(LipSyncError, match="not found"):
        load_lipsync(tmp_path / "nope.csv")
    with pytest.raises(LipSyncError, match="cannot read"):
        load_lipsync(_write(tmp_path, "time,jawOpen\n0,\xff\n", encoding="latin-1"))


def test_from_arrays() -> None:
    lipsync = LipSync.from_arrays([0, 0.5, 1.0], {"jawOpen": [0, 1, 0]})
    assert lipsync.values.shape == (3, len(LIPSYNC_NAMES))
