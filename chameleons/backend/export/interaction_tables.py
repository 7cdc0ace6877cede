"""The export's tables of the interactions: one row per interaction (what ran, the
ranking, the negotiation, the robot's speech, the synchrony) and one per suggestion.
"""

from __future__ import annotations

from chameleons.backend.export.column_spec import (
    Column,
    TableSpec,
    accepted_column,
    condition_column,
    decided_column,
    interaction_status_column,
    list_column,
    participant_column,
    position_column,
    session_column,
    time_column,
)
from chameleons.backend.export.copy_realised import realised_columns
from chameleons.backend.export.synchrony_columns import synchrony_columns
from chameleons.experiment.model import Study as StudySpec
from chameleons.experiment.suggestions import FALLBACK_WORDS


def interactions_table(spec: StudySpec) -> TableSpec:
    return TableSpec(
        "interactions",
        f"One row per interaction ({spec.interactions_per_session} per session).",
        (
            participant_column(),
            session_column(),
            position_column(spec),
            Column(
                "planned_condition",
                "string",
                "Condition the plan prescribed.",
                ", ".join(spec.condition_ids),
            ),
            condition_column(spec),
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
            list_column("presented_order", "Order the items were shown in"),
            list_column("initial_ranking", "The participant's ranking before the negotiation"),
            list_column("final_ranking", "The ranking after the robot's suggestions"),
            Column(
                "initial_error",
                "integer",
                "Error score of the initial ranking: sum of |rank - expert rank| over the"
                " interaction's items, ranks within the item set (0 = expert order).",
            ),
            Column(
                "final_error", "integer", "Error score of the final ranking (as initial_error)."
            ),
            accepted_column(spec, "Suggestions the participant accepted."),
            decided_column(spec),
            interaction_status_column(),
            time_column("started_at", "Interaction start"),
            time_column("ended_at", "Interaction end"),
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
                "The robot face the study's condition chose (2d: the virtual display's flat "
                "face, 3d: its 3D head, furhat: the booth's Furhat); empty where the "
                "condition names none (the booth's own choice applied).",
                "2d, 3d, furhat",
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
            *realised_columns(),
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
            participant_column(),
            session_column(),
            position_column(spec),
            condition_column(spec),
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
            time_column("proposed_at", "When the suggestion was made"),
            time_column("decided_at", "When the decision was recorded"),
            Column("decision_s", "number", "Seconds from proposal to decision."),
            Column("direction", "string", "Which way the item was to move.", "up, down"),
        ),
    )
