"""The negotiation step: exactly N suggestions from the policy, each accepted or declined.

Suggestion k is proposed when suggestion k-1 has been decided, from the ranking as it is
then and the items declined so far; its random generator is seeded from the plan seed,
the plan row, the participant and the interaction, so an undo followed by the same
decision proposes the same next suggestion again.
"""

from __future__ import annotations

from datetime import UTC, datetime

from chameleons.backend.models import Interaction, Suggestion
from chameleons.backend.sessions.flow import Flow, as_utc, undo_deadline
from chameleons.backend.sessions.pausing import refuse_if_paused
from chameleons.backend.sessions.policy import accept, move, propose
from chameleons.backend.studies.errors import InvalidInputError


def suggestion_count(flow: Flow) -> int:
    return flow.spec.suggestions_per_interaction


def propose_next(flow: Flow, interaction: Interaction) -> Suggestion | None:
    existing = flow.suggestions(interaction)
    index = len(existing) + 1
    if index > suggestion_count(flow):
        return None
    ranking = list(interaction.current_ranking or interaction.presented_order)
    declined = {s.item for s in existing if s.accepted is False}
    expert = flow.spec.expert_order(interaction.task, ranking)
    seed = (
        f"{flow.study.plan_seed}/{flow.row_number()}/{flow.participant.code}/"
        f"{interaction.position}/{index}"
    )
    proposal = propose(ranking, expert, declined, seed, flow.spec.suggestion_rule)
    suggestion = Suggestion(
        interaction_id=interaction.id,
        index=index,
        item=proposal.item,
        from_rank=proposal.from_rank,
        to_rank=proposal.to_rank,
        kind=proposal.kind,
    )
    flow.db.add(suggestion)
    flow.db.flush()
    flow.suggestion_added(suggestion)
    flow.log(
        "suggestion.proposed",
        source="server",
        interaction=interaction,
        payload={"position": interaction.position, **_describe(suggestion)},
    )
    return suggestion


def decide(
    flow: Flow, position: int, index: int, accepted: bool, worker_time: float | None = None
) -> Suggestion:
    interaction = _negotiating(flow, position, "decide a suggestion")
    suggestions = flow.suggestions(interaction)
    pending = next((s for s in suggestions if s.accepted is None), None)
    chosen = next((s for s in suggestions if s.index == index), None)
    if chosen is None and not 1 <= index <= suggestion_count(flow):
        raise InvalidInputError(
            f"There is no suggestion {index}; an interaction has {suggestion_count(flow)}."
        )
    if chosen is not None and chosen.accepted is not None:
        verdict = "accepted" if chosen.accepted else "declined"
        raise flow.refuse(f"Suggestion {index} of interaction {position} is already {verdict}.")
    if chosen is None or pending is None or chosen.index != pending.index:
        raise flow.refuse(
            f"Suggestion {index} of interaction {position} has not been proposed yet."
        )
    chosen.accepted = accepted
    chosen.decided_at = datetime.now(UTC)
    if accepted:
        ranking = list(interaction.current_ranking or [])
        interaction.current_ranking = accept(ranking, chosen.item, chosen.from_rank, chosen.to_rank)
    flow.db.flush()
    flow.log(
        "suggestion.decided",
        interaction=interaction,
        worker_time=worker_time,
        payload={
            "position": position,
            **_describe(chosen),
            "accepted": accepted,
            "ranking": list(interaction.current_ranking or []),
        },
    )
    propose_next(flow, interaction)
    return chosen


def undo(flow: Flow, position: int, index: int, now: datetime | None = None) -> Suggestion:
    """Take back the last decision within the undo window (the wizard mis-clicked)."""
    interaction = _negotiating(flow, position, "undo a decision")
    suggestions = flow.suggestions(interaction)
    decided = [s for s in suggestions if s.accepted is not None]
    if not decided or decided[-1].index != index:
        last = f"suggestion {decided[-1].index}" if decided else "nothing yet"
        raise flow.refuse(
            f"Only the last decision can be undone; in interaction {position} that is {last}."
        )
    chosen = decided[-1]
    deadline = undo_deadline(chosen)
    moment = as_utc(now or datetime.now(UTC))
    if deadline is None or moment > deadline:
        raise flow.refuse(f"It is too late to undo suggestion {index}: the undo window has passed.")
    withdrawn = [s for s in suggestions if s.index > index]
    for later in withdrawn:
        flow.db.delete(later)
    flow.suggestions_removed(withdrawn)
    if chosen.accepted:
        ranking = list(interaction.current_ranking or [])
        interaction.current_ranking = move(ranking, chosen.item, chosen.from_rank)
    was_accepted = chosen.accepted
    chosen.accepted = None
    chosen.decided_at = None
    flow.db.flush()
    flow.log(
        "suggestion.undone",
        interaction=interaction,
        payload={
            "position": position,
            **_describe(chosen),
            "was_accepted": was_accepted,
            "withdrawn_proposals": [s.index for s in withdrawn],
            "ranking": list(interaction.current_ranking or []),
        },
    )
    return chosen


def _negotiating(flow: Flow, position: int, doing: str) -> Interaction:
    if flow.session.state != "running":
        raise flow.refuse(f"Cannot {doing}: the session is {flow.session.state}.")
    refuse_if_paused(flow, f"to {doing}")
    interaction = flow.interaction(position)
    if interaction.state != "negotiation":
        raise flow.refuse(
            f"Cannot {doing}: interaction {position} is in {interaction.state}, not negotiation."
        )
    return interaction


def _describe(suggestion: Suggestion) -> dict[str, object]:
    return {
        "index": suggestion.index,
        "item": suggestion.item,
        "from_rank": suggestion.from_rank,
        "to_rank": suggestion.to_rank,
        "kind": suggestion.kind,
    }
