"""The simulated phone: a plausible face, sent in the real wire formats, read by the receivers."""

from __future__ import annotations

import math
import socket
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
import zmq
from click.testing import CliRunner

from chameleons.cli.main import cli
from chameleons.cli.simulate_face_command import parse_target
from chameleons.worker.frames import BLENDSHAPE_INDEX, FaceFrame
from chameleons.worker.ingest.receivers import FaceCaptureXReceiver, LiveLinkReceiver
from chameleons.worker.ingest.wire import (
    build_facecapturex_frame,
    build_livelink_packet,
    livelink_values,
)
from chameleons.worker.simulate import (
    CHECK_SWAY,
    NOD_DEG,
    TURN_DEG,
    CuedMoves,
    FaceSample,
    LiveLinkSender,
    SyntheticFace,
    run_simulation,
)
from tests.worker.face_subscriber import FaceSubscriber

HOST = "127.0.0.1"
SYNC = 0.875


@pytest.fixture
def subscriber() -> Iterator[FaceSubscriber]:
    context: zmq.Context[zmq.Socket[bytes]] = zmq.Context()
    sub = FaceSubscriber(context)
    yield sub
    sub.socket.close(linger=0)
    context.term()


def not_sync(frame: FaceFrame) -> bool:
    return float(frame.blendshapes[BLENDSHAPE_INDEX["cheekPuff"]]) != SYNC


def sync_shapes() -> np.ndarray:
    shapes = np.zeros(52, dtype=np.float32)
    shapes[BLENDSHAPE_INDEX["cheekPuff"]] = SYNC
    return shapes


def test_synthetic_face_is_plausible_and_deterministic() -> None:
    face = SyntheticFace(seed=3)
    samples = list(face.samples(fps=60, duration=40))
    assert len(samples) == 2400
    shapes = np.stack([s.blendshapes for s in samples])
    head = np.stack([s.head for s in samples])
    assert shapes.min() >= 0
    assert shapes.max() <= 1
    blink = shapes[:, BLENDSHAPE_INDEX["eyeBlinkLeft"]]
    blinks = np.sum((blink[1:] > 0.9) & (blink[:-1] <= 0.9))
    assert 40 / 6 - 1 <= blinks <= 40 / 2 + 1  # one every 2-6 s
    assert shapes[:, BLENDSHAPE_INDEX["jawOpen"]].max() > 0.2  # talks
    assert shapes[:, BLENDSHAPE_INDEX["jawOpen"]].min() < 0.01  # and pauses
    assert shapes[:, BLENDSHAPE_INDEX["mouthSmileLeft"]].max() > 0.3
    assert shapes[:, BLENDSHAPE_INDEX["browInnerUp"]].max() > 0.3
    assert 4 < np.abs(head[:, 0]).max() < 20  # head sway in degrees, not radians
    assert np.abs(np.diff(head, axis=0)).max() < 1.0  # smooth at 60 fps
    again = SyntheticFace(seed=3).sample(12.345)
    np.testing.assert_array_equal(again.blendshapes, face.sample(12.345).blendshapes)
    assert not np.array_equal(SyntheticFace(seed=4).sample(12.345).head, again.head)


class Recording:
    """Wraps a sender and keeps what was sent."""

    def __init__(self, inner: LiveLinkSender) -> None:
        self.inner = inner
        self.sent: list[FaceSample] = []

    def send(self, sample: FaceSample) -> None:
        self.sent.append(sample)
        self.inner.send(sample)

    def close(self) -> None:
        self.inner.close()


def test_simulated_livelink_arrives_as_sent(subscriber: FaceSubscriber) -> None:
    receiver = LiveLinkReceiver(host=HOST, port=0, publish_endpoint=subscriber.endpoint,
                                context=subscriber.context)  # fmt: skip
    receiver.start()
    probe = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    try:
        packet = build_livelink_packet(livelink_values(sync_shapes()))
        subscriber.receive(1, send=lambda: probe.sendto(packet, (HOST, receiver.port)))
        sender = Recording(LiveLinkSender(HOST, receiver.port, fps=120))
        sent = run_simulation(sender, SyntheticFace(seed=1).samples(fps=120, duration=0.25))
        got = subscriber.receive(25, accept=not_sync)
    finally:
        receiver.stop()
        probe.close()
    assert sent == 30
    sent_heads = np.stack([s.head for s in sender.sent])
    sent_shapes = np.stack([s.blendshapes for s in sender.sent])
    for frame in got:
        i = int(np.argmin(np.abs(sent_heads - frame.head).sum(axis=1)))
        np.testing.assert_allclose(frame.head, sent_heads[i], atol=1e-4)
        np.testing.assert_allclose(frame.blendshapes, sent_shapes[i], atol=1e-6)
        np.testing.assert_allclose(frame.eyes, sender.sent[i].eyes, atol=1e-4)
    captures = np.array([f.capture_time for f in got])
    assert np.all(np.diff(captures) > 0)  # frame numbers on a timecode clock


def test_cli_facecapturex_reaches_the_receiver(subscriber: FaceSubscriber) -> None:
    receiver = FaceCaptureXReceiver(host=HOST, port=0, publish_endpoint=subscriber.endpoint,
                                    context=subscriber.context)  # fmt: skip
    receiver.start()
    try:
        with socket.create_connection((HOST, receiver.port), timeout=5) as phone:
            sync = build_facecapturex_frame(sync_shapes())
            subscriber.receive(1, send=lambda: phone.sendall(sync))
        target = f"{HOST}:{receiver.port}"
        result = CliRunner().invoke(
            cli, ["simulate-face", "--protocol", "facecapturex", "--target", target,
                  "--fps", "100", "--duration", "0.3", "--seed", "5"],
        )  # fmt: skip
        assert result.exit_code == 0, result.output
        assert "sent 30 frames" in result.output
        got = subscriber.receive(30, accept=not_sync)
        stats = receiver.stats.snapshot()
    finally:
        receiver.stop()
    expected = [SyntheticFace(seed=5).sample(i / 100) for i in range(30)]
    np.testing.assert_allclose([f.head for f in got], [s.head for s in expected], atol=1e-3)
    assert stats["drops"] == {}
    assert stats["unknown_names"] == 0


def test_cli_replays_a_take_with_the_ingest_rotation_scale(
    tmp_path: Path, subscriber: FaceSubscriber
) -> None:
    from tests.worker.test_takes import HEADER, row, timecode

    step = math.radians(9.0)
    rows = [row(timecode(2 * i), {"HeadYaw": step * i, "JawOpen": 0.1 * i}) for i in range(8)]
    take = tmp_path / "take.csv"
    take.write_text("\n".join(",".join(r) for r in [HEADER, *rows]) + "\n")
    receiver = LiveLinkReceiver(host=HOST, port=0, publish_endpoint=subscriber.endpoint,
                                context=subscriber.context)  # fmt: skip
    receiver.start()
    probe = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    try:
        packet = build_livelink_packet(livelink_values(sync_shapes()))
        subscriber.receive(1, send=lambda: probe.sendto(packet, (HOST, receiver.port)))
        target = f"{HOST}:{receiver.port}"
        result = CliRunner().invoke(cli, ["simulate-face", "--csv", str(take), "--target", target])
        assert result.exit_code == 0, result.output
        assert "sent 8 frames" in result.output
        got = subscriber.receive(8, accept=not_sync)
    finally:
        receiver.stop()
        probe.close()
    # HeadYaw 9 degrees per row in the take's unit (radians) arrives as 9 degrees per row
    np.testing.assert_allclose([f.head[0] for f in got], [9.0 * i for i in range(8)], atol=1e-3)
    np.testing.assert_allclose(
        [f.blendshapes[BLENDSHAPE_INDEX["jawOpen"]] for f in got], [0.1 * i for i in range(8)],
        atol=1e-6,
    )  # fmt: skip


def test_cli_reports_a_refused_connection_and_a_broken_take(tmp_path: Path) -> None:
    with socket.socket() as unused:
        unused.bind((HOST, 0))
        port = unused.getsockname()[1]  # bound but not listening: connection refused
        result = CliRunner().invoke(
            cli, ["simulate-face", "--protocol", "facecapturex", "--target", f"{HOST}:{port}",
                  "--duration", "0.1"],
        )  # fmt: skip
    assert result.exit_code == 1
    assert f"cannot connect to {HOST}:{port}" in result.output
    bad = tmp_path / "bad.csv"
    bad.write_text("Timecode,Nonsense\n")
    result = CliRunner().invoke(cli, ["simulate-face", "--csv", str(bad), "--target", "9"])
    assert result.exit_code == 1
    assert "bad.csv:1: missing blendshape columns" in result.output


@pytest.mark.parametrize(
    ("text", "expected"),
    [(None, ("127.0.0.1", 11111)), ("10.0.0.5:9000", ("10.0.0.5", 9000)),
     ("9000", ("127.0.0.1", 9000)), ("phone.local", ("phone.local", 11111)),
     ("[::1]:9000", ("::1", 9000)), (":9000", ("127.0.0.1", 9000))],
)  # fmt: skip
def test_parse_target(text: str | None, expected: tuple[str, int]) -> None:
    assert parse_target(text, 11111) == expected


def test_help_lists_the_options() -> None:
    result = CliRunner().invoke(cli, ["simulate-face", "--help"])
    assert result.exit_code == 0
    for option in ("--protocol", "--target", "--fps", "--duration", "--csv", "--seed"):
        assert option in result.output


def test_cued_moves_turn_and_nod_within_the_time_asked_and_damp_the_sway() -> None:
    """The booth check's moves: a turn to the participant's left (yaw > 0) and back, a nod
    (pitch > 0), each inside the seconds asked for; meanwhile the idle sway is damped."""
    clock = [100.0]
    moves = CuedMoves(clock=lambda: clock[0])
    sway = np.array([8.0, -4.0, 2.0], dtype=np.float32)
    assert np.array_equal(moves.head(100.0, sway.copy()), sway)  # nothing cued: the sway
    assert moves.cue("rest", 2.0)
    assert moves.cue("turn", 4.0, at=102.0)
    assert moves.cue("nod", 4.0, at=106.0)
    assert not moves.cue("dance", 1.0)
    assert not moves.cue("turn", -1.0)
    moves.follow(['{"move": "copy", "seconds": 6.5}\n', "{not json\n", '{"move": 3}\n'])
    turn = [float(moves.head(102.0 + u * 4.0, sway.copy())[0]) for u in np.linspace(0, 1, 81)]
    nod = [float(moves.head(106.0 + u * 4.0, sway.copy())[1]) for u in np.linspace(0, 1, 81)]
    assert max(turn) == pytest.approx(TURN_DEG + 8.0 * CHECK_SWAY, abs=0.05)
    assert turn[0] == turn[-1] == pytest.approx(8.0 * CHECK_SWAY)  # out and back in the time
    assert max(nod) == pytest.approx(NOD_DEG - 4.0 * CHECK_SWAY, abs=0.05)
    assert (moves.cued, moves.refused) == (4, 4)
    quiet = moves.head(101.0, sway.copy())  # holding still: the sway damped
    np.testing.assert_allclose(quiet, sway * CHECK_SWAY, atol=1e-5)


def test_cli_follows_the_booth_checks_cues_on_its_standard_input(
    subscriber: FaceSubscriber,
) -> None:
    """``simulate-face --follow-cues`` (what ``chameleons demo`` runs): a turn cue written to
    its standard input turns the simulated head 40 degrees to the left and back."""
    receiver = LiveLinkReceiver(host=HOST, port=0, publish_endpoint=subscriber.endpoint,
                                context=subscriber.context)  # fmt: skip
    receiver.start()
    command = [sys.executable, "-m", "chameleons", "simulate-face", "--follow-cues",
               "--target", f"{HOST}:{receiver.port}", "--duration", "20"]  # fmt: skip
    process = subprocess.Popen(command, stdin=subprocess.PIPE, stdout=subprocess.DEVNULL)
    try:
        subscriber.receive(30, timeout=30)  # the simulator is sending
        assert process.stdin is not None
        process.stdin.write(b'{"move": "turn", "seconds": 1.5}\n')
        process.stdin.flush()
        yaws = [float(f.head[0]) for f in subscriber.receive(150, timeout=30)]
    finally:
        process.terminate()
        process.wait(timeout=10)
        if process.stdin is not None:
            process.stdin.close()
        receiver.stop()
    # The idle sway alone stays within 13 degrees; during the check it is damped.
    assert max(yaws) > TURN_DEG - 13.0 * CHECK_SWAY - 0.5
    assert max(yaws[:5]) < 15.0
