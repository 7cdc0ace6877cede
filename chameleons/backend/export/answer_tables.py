"""The export's tables of the participants' answers: every questionnaire answer, and the
scales' scores per interaction.
"""

from __future__ import annotations

from chameleons.backend.export.column_spec import (
    Column,
    TableSpec,
    accepted_column,
    condition_column,
    decided_column,
    exclusion_columns,
    interaction_status_column,
    language_column,
    participant_column,
    position_column,
    session_column,
    time_column,
)
from chameleons.experiment.model import Study as StudySpec


def questionnaire_table(spec: StudySpec) -> TableSpec:
    return TableSpec(
        "questionnaire",
        "One row per questionnaire answer (long format).",
        (
            participant_column(),
            session_column(),
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
            language_column(
                "Language of the wording (one version id covers every language).", spec
            ),
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
            time_column("answered_at", "When the answer was stored"),
        ),
    )


def scores_table(spec: StudySpec) -> TableSpec:
    scored = [q for q in spec.questionnaires_for("interaction") if q.scored]
    return TableSpec(
        "scores",
        "One row per participant x planned interaction: the analysed measures (input to the"
        " Friedman tests); interactions that did not run are rows with empty measures.",
        (
            participant_column(),
            condition_column(spec),
            position_column(spec),
            accepted_column(spec, "Accepted robot suggestions in that interaction."),
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
            decided_column(spec),
            interaction_status_column(),
            Column(
                "session_status",
                "string",
                "The participant's session: complete, in_progress, not_started (registered,"
                " never started) or ended_early (ended by the wizard; reason in"
                " participants.csv).",
                "complete, in_progress, not_started, ended_early",
            ),
            *exclusion_columns(),
        ),
    )
