"""States of a session and its interactions, and what the wizard may do next (in words).

Per interaction: pending -> discussion -> ranking -> negotiation -> questionnaire -> done.
The wizard moves an interaction up to ``questionnaire``; the participant's last
questionnaire answer makes it ``done``. A session is pending -> running ->
final_questionnaire -> complete; the participant's final answers complete it.
"""

from __future__ import annotations

import itertools
from typing import Any

SESSION_STATES = ("pending", "running", "final_questionnaire", "complete")
STEPS = ("pending", "discussion", "ranking", "negotiation", "questionnaire", "done")
WIZARD_STEPS = ("discussion", "ranking", "negotiation", "questionnaire")
NEXT_STEP = dict(itertools.pairwise(STEPS))
UNDO_WINDOW_SECONDS = 10.0

Action = dict[str, Any]


def describe(action: Action) -> str:
    kind = action["action"]
    position = action.get("position")
    if kind == "start":
        return "start the session"
    if kind == "advance":
        return f"move interaction {position} to {action['to']}"
    if kind == "decide":
        return f"accept or decline suggestion {action['index']} of interaction {position}"
    if kind == "undo":
        return f"undo the decision on suggestion {action['index']} of interaction {position}"
    if kind == "wait":
        waited = action["for"]
        if waited == "ranking":
            return f"wait for the participant's ranking in interaction {position}"
        if waited == "questionnaire":
            return f"wait for the participant's questionnaire after interaction {position}"
        return "wait for the participant's final questionnaire"
    return "nothing: the session is complete"


def allowed_sentence(actions: list[Action]) -> str:
    return "Allowed now: " + "; or ".join(describe(a) for a in actions) + "."
