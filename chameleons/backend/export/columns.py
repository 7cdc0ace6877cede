"""The export's tables and columns: one definition feeds the writers and the codebook.

Column names are stable API (R and pandas scripts use them): add columns, never rename.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

from chameleons.backend.sessions.states import END_REASONS
from chameleons.experiment.model import Study as StudySpec
from chameleons.experiment.suggestions import FALLBACK_WORDS

ColumnType = Literal["string", "integer", "number", "boolean", "datetime"]
LIST_SEPARATOR = ";"
TIME_NOTE = (
    "ISO 8601 in UTC with millisecond precision, e.g. 2026-03-02T09:00:00.000+00:00; in"
    " data.xlsx an Excel date-time in UTC (Excel stores no time zone)"
)


@dataclass(frozen=True)
class Column:
    name: str
    type: ColumnType
    description: str
    values: str = ""
    identifying: bool = False


@dataclass(frozen=True)
class TableSpec:
    name: str
    description: str
    columns: tuple[Column, ...]

    @property
    def column_names(self) -> list[str]:
        return [column.name for column in self.columns]


def _participant() -> Column:
    return Column("participant", "string", "Pseudonymous participant code (no names are stored).")


def _session() -> Column:
    return Column("session", "integer", "Session id (a participant normally has one session).")


def _position(spec: StudySpec) -> Column:
    k = spec.interactions_per_session
    return Column("position", "integer", "Interaction position in the session.", f"1..{k}")


def _condition(spec: StudySpec, what: str = "Condition actually run.") -> Column:
    return Column("condition", "string", what, ", ".join(spec.condition_ids))


def _time(name: str, what: str) -> Column:
    return Column(name, "datetime", f"{what} ({TIME_NOTE}).")


def _list(name: str, what: str) -> Column:
    return Column(name, "string", f"{what}; item ids joined by '{LIST_SEPARATOR}', first = rank 1.")


def _exclusion_columns() -> tuple[Column, Column]:
    return (
        Column(
            "excluded",
            "boolean",
            "The PI excluded the participant from the analysis (data kept): every analysis"
            " view leaves them out and says why.",
        ),
        Column(
            "exclusion_reason",
            "string",
            "The PI's reason for the exclusion. POSSIBLY IDENTIFYING (free text).",
            identifying=True,
        ),
    )


def _decided(spec: StudySpec) -> Column:
    n = spec.suggestions_per_interaction
    return Column(
        "suggestions_decided",
        "integer",
        f"How many of the interaction's {n} suggestions were decided (accepted or declined);"
        f" below {n}: the negotiation was not finished.",
        f"0..{n}",
    )


def _interaction_status() -> Column:
    return Column(
        "interaction_status",
        "string",
        "complete: every step done; partial: started but not finished (e.g. the session"
        " ended early); not_run: never started (missing, not zero).",
        "complete, partial, not_run",
    )


def _accepted(spec: StudySpec, what: str) -> Column:
    n = spec.suggestions_per_interaction
    return Column(
        "accepted",
        "integer",
        f"{what} MISSING (empty) unless all {n} suggestions were decided: an interaction that"
        " never ran or stopped early has no count (never 0).",
        f"0..{n}",
    )


def _language(description: str, spec: StudySpec) -> Column:
    return Column("language", "string", description, ", ".join(spec.languages))


def participants_table(spec: StudySpec) -> TableSpec:
    return TableSpec(
        "participants",
        "One row per participant, with their (last) session.",
        (
            _participant(),
            Column("plan_row", "integer", "Counterbalancing plan row the participant ran."),
            Column(
                "status",
                "string",
                "Participant status.",
                "registered, active, complete, ended_early, declined",
            ),
            Column("rehearsal", "boolean", "Marked as a staff rehearsal, not a real participant."),
            _session(),
            Column("booth", "string", "Booth the session ran in."),
            _language("The participant's language: phone pages, study texts and prompts.", spec),
            Column(
                "session_state",
                "string",
                "Session state at export time (ended: ended early by the wizard).",
                "pending, running, final_questionnaire, complete, ended",
            ),
            _time(
                "consent_at",
                "When the participant agreed on the phone's consent page; empty for a study"
                " without one and for a participant who declined (end_reason consent_declined)",
            ),
            _time("started_at", "Session start"),
            _time("completed_at", "Session completion"),
            Column("duration_s", "number", "Session duration in seconds (start to completion)."),
            _time("ended_at", "When the wizard ended the session early; empty otherwise"),
            Column(
                "end_reason",
                "string",
                "Why the session was ended early (consent_declined: the participant declined"
                " on the consent page; nothing else was recorded); empty otherwise.",
                ", ".join([*END_REASONS, "consent_declined"]),
            ),
            Column(
                "end_note",
                "string",
                "The wizard's note on ending early. POSSIBLY IDENTIFYING (free text).",
                identifying=True,
            ),
            Column("pause_count", "integer", "How often the wizard paused the session."),
            Column(
                "paused_s",
                "number",
                "Seconds the session was paused in total (included in duration_s; each pause"
                " and its reason is in events: session.paused, session.resumed).",
            ),
            *_exclusion_columns(),
            _time("excluded_at", "When the PI excluded the participant"),
            Column(
                "study_config_hash",
                "string",
                "sha256 of the study config the data was collected under.",
            ),
        ),
    )


def interactions_table(spec: StudySpec) -> TableSpec:
    from chameleons.backend.export.synchrony_columns import synchrony_columns

    return TableSpec(
        "interactions",
        f"One row per interaction ({spec.interactions_per_session} per session).",
        (
            _participant(),
            _session(),
            _position(spec),
            Column(
                "planned_condition",
                "string",
                "Condition the plan prescribed.",
                ", ".join(spec.condition_ids),
            ),
            _condition(spec),
            Column("deviation", "boolean", "The condition run differs from the planned one."),
            Column(
                "actor",
                "string",
                "Voice actor (robot personality).",
                ", ".join(a.id for a in spec.actors),
            ),
            Column("actor_gender", "string", "The actor's gender.", "female, male"),
            Column("robot_name", "string", "The robot's name in this interaction."),
            Column("face", "string", "Robot face.", ", ".join(f.id for f in spec.faces)),
            Column("task", "string", "Survival task.", ", ".join(t.id for t in spec.tasks)),
            Column("item_set", "string", "Item set of the task.", ", ".join(spec.item_sets.sets)),
            _list("presented_order", "Order the items were shown in"),
            _list("initial_ranking", "The participant's ranking before the negotiation"),
            _list("final_ranking", "The ranking after the robot's suggestions"),
            Column(
                "initial_error",
                "integer",
                "Error score of the initial ranking: sum of |rank - expert rank| over the"
                " interaction's items, ranks within the item set (0 = expert order).",
            ),
            Column(
                "final_error", "integer", "Error score of the final ranking (as initial_error)."
            ),
            _accepted(spec, "Suggestions the participant accepted."),
            _decided(spec),
            _interaction_status(),
            _time("started_at", "Interaction start"),
            _time("ended_at", "Interaction end"),
            Column("duration_s", "number", "Interaction duration in seconds."),
            Column(
                "behaviour",
                "string",
                "The behaviour the robot ran for the condition (the study's conditions say "
                "with which parameters).",
                ", ".join(sorted({c.behaviour for c in spec.conditions})),
            ),
            Column(
                "natural_source",
                "string",
                "What the natural behaviour replayed in this interaction: clip (one fixed "
                "recording), yoked (another participant's recorded face) or synthetic; empty "
                "when natural never ran in it.",
                "clip, yoked, synthetic",
            ),
            Column(
                "natural_recording",
                "string",
                "Which recording natural replayed (clip name, or the participant, interaction "
                "and recording id it was yoked to).",
            ),
            Column(
                "renderer",
                "string",
                "The virtual robot display's face the study's condition chose (2d: the flat "
                "face, 3d: the 3D head); empty where the condition names none (the booth's "
                "own choice applied, or the robot is a Furhat).",
                "2d, 3d",
            ),
            # issue 31: the behaviour's design-space parameters, per interaction
            Column(
                "behaviour_params",
                "string",
                "The parameters the worker was sent for the interaction's behaviour, as JSON "
                "with sorted keys (copy: delay in seconds or a distribution, channels, gain, "
                "mirror, coexpress, intermittent, only, seed; absent keys have their defaults, "
                "docs/design-space.md); empty before the robot was set up.",
            ),
            Column(
                "behaviour_words",
                "string",
                "The same in words: what the robot copied, how late, how much and how often "
                "(e.g. 'copies head, 4 s late, mirror image').",
            ),
            Column(
                "recording_problem",
                "string",
                "Why the face recording of this interaction failed or never started (e.g. a "
                "full disk or a read-only recordings folder); empty when it was recorded.",
            ),
            # Issue 29: what captured the participant (the analysis can split by it).
            Column(
                "face_source",
                "string",
                "The capture source most of the participant's recorded frames came from: "
                "livelink (iPhone, Live Link Face), facecapturex (iPhone, FaceCaptureX), "
                "webcam-browser (a webcam on the booth's capture page), webcam-python (a "
                "webcam the worker tracked itself); empty when nothing was recorded.",
                "livelink, facecapturex, webcam-browser, webcam-python",
            ),
            Column(
                "face_calibration",
                "string",
                "How a webcam source was calibrated: geometric (the default mapping, not "
                "calibrated), neutral (the participant's own neutral face), iphone:<hash> (the "
                "lab's iPhone-taught map), neutral+iphone:<hash> (both); empty for an iPhone "
                "source, which needs none.",
                "geometric, neutral, iphone:<hash>, neutral+iphone:<hash>",
            ),
            *synchrony_columns(),
        ),
    )


def suggestions_table(spec: StudySpec) -> TableSpec:
    return TableSpec(
        "suggestions",
        f"One row per robot suggestion ({spec.suggestions_per_interaction} per interaction).",
        (
            _participant(),
            _session(),
            _position(spec),
            _condition(spec),
            Column(
                "index",
                "integer",
                "Suggestion number within the interaction.",
                f"1..{spec.suggestions_per_interaction}",
            ),
            Column("item", "string", "Item the robot proposed to move."),
            Column("from_rank", "integer", "The item's rank when proposed (1 = most important)."),
            Column(
                "to_rank",
                "integer",
                "Rank the robot proposed (above from_rank, or below it when an optimal "
                "suggestion moves an item down).",
            ),
            Column(
                "kind",
                "string",
                f"optimal: the {spec.suggestion_rule} rule's move toward the expert order;"
                f" random: the fallback (a random move up) {FALLBACK_WORDS[spec.suggestion_rule]}."
                " The kind depends on the participant's earlier decisions (a mediator): "
                "compare conditions without adjusting for it.",
                "optimal, random",
            ),
            Column("accepted", "boolean", "The participant's decision; empty if never decided."),
            _time("proposed_at", "When the suggestion was made"),
            _time("decided_at", "When the decision was recorded"),
            Column("decision_s", "number", "Seconds from proposal to decision."),
            Column("direction", "string", "Which way the item was to move.", "up, down"),
        ),
    )


def questionnaire_table(spec: StudySpec) -> TableSpec:
    return TableSpec(
        "questionnaire",
        "One row per questionnaire answer (long format).",
        (
            _participant(),
            _session(),
            Column(
                "position",
                "integer",
                "Interaction the answer is about; 0 = the final questionnaire; -1 = the"
                " questions before the interactions (about the participant).",
                f"-1..{spec.interactions_per_session}",
            ),
            Column(
                "condition",
                "string",
                "Condition of that interaction; empty for the final questionnaire.",
                ", ".join(spec.condition_ids),
            ),
            Column(
                "questionnaire",
                "string",
                "Questionnaire id.",
                ", ".join(q.id for q in spec.questionnaires),
            ),
            Column("version", "string", "Wording version the answer was given to."),
            _language("Language of the wording (one version id covers every language).", spec),
            Column("item", "string", "Item id within the questionnaire."),
            Column(
                "reverse_keyed",
                "boolean",
                "The item is reverse-keyed (scored as points + 1 - value).",
            ),
            Column(
                "value",
                "integer",
                "Raw answer on the questionnaire's scale (1 = left anchor / strongly"
                " disagree); for a robot item the position of the robot named; empty for"
                " open questions and choices (their option id is in text).",
                "1..7",
            ),
            Column(
                "scored_value",
                "integer",
                "The value as it enters the score (reverse-keyed items reversed).",
            ),
            Column(
                "text",
                "string",
                "Open answer. POSSIBLY IDENTIFYING: free text may name or describe the"
                " participant; review before sharing.",
                identifying=True,
            ),
            Column(
                "named_condition",
                "string",
                "Robot items (manipulation check): the condition of the robot the answer names"
                " (value = its position in the session); empty otherwise and for 'dont_know'"
                " (in text).",
                ", ".join(spec.condition_ids),
            ),
            Column(
                "skipped",
                "boolean",
                "An optional item the participant left empty: value, scored_value and text"
                " are empty (never a default value).",
            ),
            _time("answered_at", "When the answer was stored"),
        ),
    )


def scores_table(spec: StudySpec) -> TableSpec:
    scored = [q for q in spec.questionnaires_for("interaction") if q.scored]
    return TableSpec(
        "scores",
        "One row per participant x planned interaction: the analysed measures (input to the"
        " Friedman tests); interactions that did not run are rows with empty measures.",
        (
            _participant(),
            _condition(spec),
            _position(spec),
            _accepted(spec, "Accepted robot suggestions in that interaction."),
            *(
                Column(
                    q.id,
                    "number",
                    f"{q.title} score: mean of its {len(q.numeric_items)} items, reverse-keyed"
                    " items reversed; empty if any item is missing.",
                    f"1..{q.points}",
                )
                for q in scored
            ),
            Column(
                "planned_condition",
                "string",
                "Condition the plan prescribed: the as-planned (intention-to-treat) analysis"
                " groups by it.",
                ", ".join(spec.condition_ids),
            ),
            Column(
                "deviation",
                "boolean",
                "The condition run differs from the planned one: the as-run (per-protocol)"
                " analysis leaves the participant out.",
            ),
            _decided(spec),
            _interaction_status(),
            Column(
                "session_status",
                "string",
                "The participant's session: complete, in_progress, not_started (registered,"
                " never started) or ended_early (ended by the wizard; reason in"
                " participants.csv).",
                "complete, in_progress, not_started, ended_early",
            ),
            *_exclusion_columns(),
        ),
    )


def events_table(spec: StudySpec) -> TableSpec:
    return TableSpec(
        "events",
        "One row per timeline event of the counted sessions, in time order.",
        (
            Column("event", "integer", "Event id (append-only, increasing)."),
            _participant(),
            _session(),
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
            _time("server_time", "When the server recorded it"),
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
        ("robot", "Robot connected (virtual robot: display page open and playing)"),
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
            _time("checked_at", "When the check ran"),
            Column("passed", "boolean", "No step failed (warnings allowed)."),
            *(Column(f"{step}_status", "string", f"{what}.", status) for step, what in steps),
            Column("face_fps", "number", "Face frames per second arriving from the phone."),
            Column("capture_to_send_ms", "number", "Capture to send latency of the pipeline "
                   "(ms), without the copy's intended delay."),
            Column("head_yaw_deg", "number", "Largest head turn measured from the resting pose "
                   "(degrees, left > 0)."),
            Column("head_pitch_deg", "number", "Largest nod measured from the resting pose "
                   "(degrees, down > 0)."),
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


TABLE_BUILDERS = (
    participants_table,
    interactions_table,
    suggestions_table,
    questionnaire_table,
    scores_table,
    events_table,
    booth_checks_table,
)
TABLE_NAMES = ("participants", "interactions", "suggestions", "questionnaire", "scores", "events",
               "booth_checks")  # fmt: skip


def table_specs(spec: StudySpec) -> list[TableSpec]:
    return [build(spec) for build in TABLE_BUILDERS]


CODEBOOK_COLUMNS = ("table", "column", "type", "description", "values", "possibly_identifying")


def codebook_rows(specs: list[TableSpec]) -> list[dict[str, object]]:
    return [
        {
            "table": table.name,
            "column": column.name,
            "type": column.type,
            "description": column.description,
            "values": column.values,
            "possibly_identifying": column.identifying,
        }
        for table in specs
        for column in table.columns
    ]
