"""Parquet face recordings: round trip, chunked journal, what survives a crash."""

from __future__ import annotations

import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import pytest

from chameleons.worker.frames import BLENDSHAPE_NAMES, FaceFrame
from chameleons.worker.recording import (
    FrameRecorder,
    RecordingError,
    journal_path,
    read_recording,
    read_recording_table,
    recorded_sources,
    recording_metadata,
    recover_recording,
)


def frames(n: int, seed: int = 0, start: float = 100.0) -> list[FaceFrame]:
    rng = np.random.default_rng(seed)
    out = []
    for i in range(n):
        vector = rng.uniform(-30, 30, FaceFrame.VECTOR_SIZE).astype(np.float32)
        vector[:52] = rng.uniform(0, 1, 52)
        t = start + i / 60
        out.append(FaceFrame.from_vector(vector, t, t + 0.004, "test"))
    return out


def test_round_trip(tmp_path: Path) -> None:
    path = tmp_path / "interaction-7" / "participant.parquet"
    recorded = frames(200)
    with FrameRecorder(path, metadata={"interaction": 7, "stream": "participant"}) as recorder:
        for frame in recorded:
            recorder.write(frame)
    assert path.exists()
    assert not journal_path(path).exists()
    table = read_recording_table(path)
    assert table.column_names[:3] == ["capture_time", "receive_time", BLENDSHAPE_NAMES[0]]
    assert {"head_yaw", "head_pitch", "head_roll", "left_eye_yaw", "right_eye_roll"} <= set(
        table.column_names
    )
    assert recording_metadata(table) == {"version": 2, "interaction": 7, "stream": "participant"}
    np.testing.assert_array_equal(
        table.column("receive_time").to_numpy(), [f.receive_time for f in recorded]
    )
    take = read_recording(path)
    np.testing.assert_allclose(take.times, np.arange(200) / 60, atol=1e-9)
    np.testing.assert_array_equal(take.blendshapes, np.stack([f.blendshapes for f in recorded]))
    np.testing.assert_array_equal(take.head, np.stack([f.head for f in recorded]))
    np.testing.assert_array_equal(take.eyes, np.stack([f.eyes for f in recorded]))
    assert pq.ParquetFile(path).metadata.num_rows == 200


def test_chunks_reach_the_journal_by_count_and_by_time(tmp_path: Path) -> None:
    now = [0.0]
    path = tmp_path / "r.parquet"
    recorder = FrameRecorder(path, chunk_frames=50, chunk_seconds=0.5, clock=lambda: now[0])
    data = frames(80)
    for frame in data[:60]:
        recorder.write(frame)
    assert read_recording_table(path).num_rows == 50  # one full chunk, 10 still buffered
    now[0] = 0.6
    recorder.write(data[60])  # half a second since the last chunk: flushed
    assert read_recording_table(path).num_rows == 61
    recorder.close()
    assert read_recording_table(path).num_rows == 61


def test_a_chunk_that_is_due_is_flushed_without_a_next_frame(tmp_path: Path) -> None:
    """The stream paused (the face left): what was buffered reaches the journal once a
    chunk's time passed, not only with a next frame that may never come."""
    now = [0.0]
    path = tmp_path / "r.parquet"
    recorder = FrameRecorder(path, chunk_frames=50, chunk_seconds=0.5, clock=lambda: now[0])
    recorder.flush_if_due()  # nothing buffered: nothing to write
    assert recorder.frames_written == 0
    for frame in frames(20):
        recorder.write(frame)
    now[0] = 0.4
    recorder.flush_if_due()  # not due yet
    assert recorder.frames_written == 0
    now[0] = 0.5
    recorder.flush_if_due()
    assert (read_recording_table(path).num_rows, recorder.frames_written) == (20, 20)
    recorder.close()
    assert read_recording_table(path).num_rows == 20


def test_truncated_journal_is_readable_up_to_the_last_full_chunk(tmp_path: Path) -> None:
    path = tmp_path / "r.parquet"
    recorder = FrameRecorder(path, chunk_frames=40)
    sizes = []
    for frame in frames(120):
        recorder.write(frame)
        sizes.append(journal_path(path).stat().st_size)
    crashed = tmp_path / "crashed.parquet"
    journal = journal_path(path).read_bytes()
    # cut in the middle of the third chunk, as a crash during its write would
    cut = (sizes[79] + sizes[119]) // 2
    journal_path(crashed).write_bytes(journal[:cut])
    recorder.close()
    take = read_recording(crashed)
    assert len(take) == 80
    np.testing.assert_array_equal(take.blendshapes, read_recording(path).blendshapes[:80])
    assert recover_recording(crashed) == crashed
    assert not journal_path(crashed).exists()
    assert len(read_recording(crashed)) == 80


CRASHING_WORKER = """
import os, sys
import numpy as np
from chameleons.worker.frames import FaceFrame
from chameleons.worker.recording import FrameRecorder
recorder = FrameRecorder(sys.argv[1], chunk_frames=50, chunk_seconds=60)
for i in range(175):
    recorder.write(FaceFrame(i / 60, i / 60, np.full(52, 0.5, np.float32)))
os._exit(1)  # killed: no close, no flush, no finalizers
"""


def test_a_real_crash_loses_at_most_the_last_chunk(tmp_path: Path) -> None:
    path = tmp_path / "crash.parquet"
    script = textwrap.dedent(CRASHING_WORKER)
    result = subprocess.run([sys.executable, "-c", script, str(path)], timeout=60, check=False)
    assert result.returncode == 1
    assert not path.exists()
    assert len(read_recording(path)) == 150  # 3 chunks of 50; the 25 buffered frames lost
    recover_recording(path)
    assert pq.ParquetFile(path).metadata.num_rows == 150


def test_times_fall_back_to_receive_time_when_the_sender_clock_restarts(tmp_path: Path) -> None:
    path = tmp_path / "r.parquet"
    data = frames(10)
    data[5].capture_time = 0.0
    with FrameRecorder(path) as recorder:
        for frame in data:
            recorder.write(frame)
    np.testing.assert_allclose(read_recording(path).times, np.arange(10) / 60, atol=1e-9)


def test_refuses_to_overwrite_and_reports_bad_files(tmp_path: Path) -> None:
    path = tmp_path / "r.parquet"
    with FrameRecorder(path) as recorder:
        recorder.write(frames(1)[0])
    with pytest.raises(FileExistsError):
        FrameRecorder(path)
    with pytest.raises(RuntimeError, match="closed"):
        recorder.write(frames(1)[0])
    with pytest.raises(RecordingError, match="no such recording"):
        read_recording(tmp_path / "absent.parquet")
    garbage = tmp_path / "garbage.parquet"
    garbage.write_bytes(b"PAR1 not really")
    with pytest.raises(RecordingError, match="not a readable Parquet"):
        read_recording(garbage)
    journal_path(tmp_path / "j.parquet").write_bytes(b"\x01\x02")
    with pytest.raises(RecordingError, match="no readable recording header"):
        read_recording(tmp_path / "j.parquet")


def test_empty_recording(tmp_path: Path) -> None:
    path = FrameRecorder(tmp_path / "e.parquet").close()
    assert read_recording_table(path).num_rows == 0
    with pytest.raises(RecordingError, match="no frames"):
        read_recording(path)


def test_missing_channels_are_nan_and_each_frame_says_its_source(tmp_path: Path) -> None:
    """A webcam cannot measure cheekPuff: the robot got 0, the recording keeps NaN; the
    frame's source and calibration are kept per frame; a replay rests (0) there."""
    path = tmp_path / "webcam.parquet"
    cheek = BLENDSHAPE_NAMES.index("cheekPuff")
    recorded = frames(4)
    for frame in recorded[:3]:
        frame.source, frame.calibration, frame.missing = "webcam-python", "neutral", (cheek,)
    with FrameRecorder(path) as recorder:
        for frame in recorded:
            recorder.write(frame)
    table = read_recording_table(path)
    column = table.column("cheekPuff").to_numpy()
    assert np.isnan(column[:3]).all()
    assert np.isfinite(column[3])
    assert recorded_sources(path) == {("webcam-python", "neutral"): 3, ("test", ""): 1}
    assert np.isfinite(read_recording(path).blendshapes).all()
