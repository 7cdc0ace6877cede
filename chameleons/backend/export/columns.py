"""The export's tables and columns: one definition feeds the writers and the codebook.

Column names are stable API (R and pandas scripts use them): add columns, never rename.
What a column is and the columns tables share are in ``column_spec``; the tables by what
they hold in ``interaction_tables`` (interactions, suggestions), ``answer_tables``
(questionnaire, scores) and ``log_tables`` (events, booth checks); the participants' table,
the list of tables and the codebook here.
"""

from __future__ import annotations

from chameleons.backend.export.answer_tables import questionnaire_table, scores_table
from chameleons.backend.export.column_spec import (
    LIST_SEPARATOR,
    TIME_NOTE,
    Column,
    ColumnType,
    TableSpec,
    exclusion_columns,
    language_column,
    participant_column,
    session_column,
    time_column,
)
from chameleons.backend.export.interaction_tables import interactions_table, suggestions_table
from chameleons.backend.export.log_tables import booth_checks_table, events_table
from chameleons.backend.sessions.states import END_REASONS
from chameleons.experiment.model import Study as StudySpec

__all__ = [
    "CODEBOOK_COLUMNS",
    "LIST_SEPARATOR",
    "TABLE_BUILDERS",
    "TABLE_NAMES",
    "TIME_NOTE",
    "Column",
    "ColumnType",
    "TableSpec",
    "booth_checks_table",
    "codebook_rows",
    "events_table",
    "interactions_table",
    "participants_table",
    "questionnaire_table",
    "scores_table",
    "suggestions_table",
    "table_specs",
]


def participants_table(spec: StudySpec) -> TableSpec:
    return TableSpec(
        "participants",
        "One row per participant, with their (last) session.",
        (
            participant_column(),
            Column("plan_row", "integer", "Counterbalancing plan row the participant ran."),
            Column(
                "status",
                "string",
                "Participant status.",
                "registered, active, complete, ended_early, declined",
            ),
            Column("rehearsal", "boolean", "Marked as a staff rehearsal, not a real participant."),
            session_column(),
            Column("booth", "string", "Booth the session ran in."),
            language_column(
                "The participant's language: phone pages, study texts and prompts.", spec
            ),
            Column(
                "session_state",
                "string",
                "Session state at export time (ended: ended early by the wizard).",
                "pending, running, final_questionnaire, complete, ended",
            ),
            time_column(
                "consent_at",
                "When the participant agreed on the phone's consent page; empty for a study"
                " without one and for a participant who declined (end_reason consent_declined)",
            ),
            Column(
                "video_consent",
                "boolean",
                "Whether the participant ticked the consent page's video item (a study with"
                " procedure.video); empty where it was not asked.",
            ),
            Column(
                "video_audio_consent",
                "boolean",
                "Whether they also ticked the microphone item (a video study that asks for"
                " sound); empty where it was not asked.",
            ),
            time_column("started_at", "Session start"),
            time_column("completed_at", "Session completion"),
            Column("duration_s", "number", "Session duration in seconds (start to completion)."),
            time_column("ended_at", "When the wizard ended the session early; empty otherwise"),
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
            *exclusion_columns(),
            time_column("excluded_at", "When the PI excluded the participant"),
            Column(
                "study_config_hash",
                "string",
                "sha256 of the study config the data was collected under.",
            ),
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
