"""The export's tables of what happened: the sessions' timeline events and the booth
checks.
"""

from __future__ import annotations

from chameleons.backend.export.column_spec import (
    Column,
    TableSpec,
    participant_column,
    session_column,
    time_column,
)
from chameleons.experiment.model import Study as StudySpec


def events_table(spec: StudySpec) -> TableSpec:
    return TableSpec(
        "events",
        "One row per timeline event of the counted sessions, in time order.",
        (
            Column("event", "integer", "Event id (append-only, increasing)."),
            participant_column(),
            session_column(),
            Column("position", "integer", "Interaction position; empty for session-level events."),
            Column(
                "kind",
                "string",
                "What happened, as area.what (e.g. session.started, interaction.advanced,"
                " prompt.played, prompt.speech_start, suggestion.decided,"
                " questionnaire.submitted, session.completed).",
            ),
            Column(
                "source",
                "string",
                "Who reported it (wizard, participant, worker, server, staff, ...).",
            ),
            time_column("server_time", "When the server recorded it"),
            Column(
                "worker_time",
                "number",
                "The worker's monotonic clock in seconds, where the worker reported it.",
            ),
            Column(
                "payload",
                "string",
                "Event details as a JSON object. POSSIBLY IDENTIFYING when it carries"
                " submitted text.",
                identifying=True,
            ),
        ),
    )


def booth_checks_table(spec: StudySpec) -> TableSpec:
    status = "pass, fail, warn (empty: the step did not exist then)"
    steps = (
        ("face", "Face stream (frames arrive, capture to robot latency)"),
        ("head", "Turn your head left, then nod (sign and size of yaw and pitch)"),
        (
            "robot",
            "Robot connected (virtual robot: display page open and playing; warn: the"
            " display painted under 10 frames a second during the check)",
        ),
        (
            "copy",
            "Robot copies the head: the check runs the robot in copy with the study's"
            " delay; fails when it does not copy or the measured delay is more than 0.25 s"
            " off the configured",
        ),
        ("speech", "Robot says a test prompt and reports its speech start and end"),
        ("disk", "Recordings folder writable, free space for a session"),
    )
    return TableSpec(
        "booth_checks",
        "One row per booth check (the check a technician runs before each participant), in"
        " time order: those run for a session of this study, and those run without a session"
        " (from the booths monitor, or between participants) with the study's copy delay.",
        (
            Column(
                "participant",
                "string",
                "Pseudonymous participant code of the session the"
                " check was run for; empty: run without a session.",
            ),
            Column(
                "session",
                "integer",
                "Session id the check was run for; empty: run without a session.",
            ),
            Column("booth", "string", "Booth id."),
            time_column("checked_at", "When the check ran"),
            Column("passed", "boolean", "No step failed (warnings allowed)."),
            *(Column(f"{step}_status", "string", f"{what}.", status) for step, what in steps),
            Column("face_fps", "number", "Face frames per second arriving from the phone."),
            Column(
                "capture_to_send_ms",
                "number",
                "Capture to send latency of the pipeline (ms), without the copy's intended delay.",
            ),
            Column(
                "head_yaw_deg",
                "number",
                "Largest head turn measured from the resting pose (degrees, left > 0).",
            ),
            Column(
                "head_pitch_deg",
                "number",
                "Largest nod measured from the resting pose (degrees, down > 0).",
            ),
            Column(
                "copy_delay_s",
                "number",
                "Copy delay the check ran the robot with: the study's configured delay (s).",
            ),
            Column(
                "measured_delay_s",
                "number",
                "Copy delay measured movement to movement: the participant's captured head"
                " yaw against the yaw sent to the robot, by cross-correlation (s).",
            ),
            Column("speech_start_ms", "number", "Test prompt: command to speech start (ms)."),
            Column("speech_ok", "boolean", "Test prompt: the robot reported start and end."),
            Column("disk_free_bytes", "integer", "Free space for recordings (bytes)."),
        ),
    )
