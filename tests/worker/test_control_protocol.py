"""The command protocol: validation, acks, errors for unknown and malformed commands."""

from __future__ import annotations

import pytest

from chameleons.worker.control import (
    COMMAND_FIELDS,
    CommandError,
    make_ack,
    make_command,
    make_error_ack,
    parse_ack,
    parse_command,
)
from chameleons.worker.envelope import Message, serialize


def _frames(kind: str, body: dict[str, object], seq: int = 7) -> list[bytes]:
    return serialize(make_command(kind, body, seq=seq))


VALID = {
    "set_behaviour": {"name": "copy", "params": {"delay": 4.0}},
    "play_prompt": {
        "prompt_id": "p1",
        "audio_url": "http://x/p1.wav",
        "lipsync_path": "/a.csv",
        "play_id": "play-7",
    },
    "stop_prompt": {},
    "set_face": {"face_id": "adult-01"},
    "start_recording": {"interaction_id": 12, "directory": "/data/rec"},
    "stop_recording": {"interaction_id": "12"},
    "status": {},
    "speech_event": {"event": "start", "prompt_id": "p1", "play_id": "play-7"},
    "retry_robot": {},
    "reset_pairing": {},
    "reset_delay_probe": {},
    "recentre_head": {"seconds": 2.0},
    "mark_head_rest": {"rest_seconds": 2.0},
    "calibrate_webcam": {"action": "start"},
}


def test_every_command_type_has_a_valid_example() -> None:
    assert set(VALID) == set(COMMAND_FIELDS)


@pytest.mark.parametrize(("kind", "body"), VALID.items())
def test_valid_commands_parse_and_ack_with_the_same_seq(kind: str, body: dict[str, object]) -> None:
    command = parse_command(_frames(kind, body, seq=41))
    assert (command.type, command.seq, command.body) == (kind, 41, body)
    ack = parse_ack(make_ack(command, {"done": True}))
    assert (ack.seq, ack.command, ack.ok, ack.result) == (41, kind, True, {"done": True})


@pytest.mark.parametrize(
    ("frames", "reason"),
    [
        (_frames("fly", {}), "unknown_command"),
        (_frames("set_behaviour", {}), "missing_field"),
        (_frames("set_behaviour", {"name": 3}), "bad_field"),
        (_frames("set_behaviour", {"name": True}), "bad_field"),
        (_frames("status", {"verbose": 1}), "unknown_field"),
        (_frames("speech_event", {"event": "middle"}), "bad_field"),
        (serialize(Message("hello", "status", seq=7)), "wrong_topic"),
        ([b"command", b"{not json", b""], "malformed"),
        ([b"only-one-part"], "malformed"),
    ],
)
def test_bad_commands_raise_a_command_error_that_answers_as_an_error_ack(
    frames: list[bytes], reason: str
) -> None:
    with pytest.raises(CommandError) as caught:
        parse_command(frames)
    assert caught.value.reason == reason
    ack = parse_ack(make_error_ack(caught.value))
    assert not ack.ok
    assert ack.error == reason
    if reason != "malformed":
        assert ack.seq == 7
    else:
        assert ack.seq == -1
