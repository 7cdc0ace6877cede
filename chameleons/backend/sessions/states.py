"""States of a session and its interactions, and what the wizard may do next (in words).

Per interaction: pending -> discussion -> ranking -> negotiation -> questionnaire -> done.
The wizard moves an interaction up to ``questionnaire``; the participant's last
questionnaire answer makes it ``done``. A session is pending -> running ->
final_questionnaire -> complete; the participant's final answers complete it. A running
session may be paused and resumed (``pausing.py``): its state stays, nothing moves on.
The wizard can end a session early from any state but complete: it becomes ``ended``
(with a reason), its interactions stay as far as they got, and nothing more happens in it.
"""

from __future__ import annotations

import itertools
from typing import Any

SESSION_STATES = ("pending", "running", "final_questionnaire", "complete", "ended")
END_REASONS = {
    "participant_withdrew": "the participant withdrew from the session",
    "technical_failure": "technical failure",
    "time": "out of time",
    "other": "other",
}
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
    if kind == "resume":
        return "resume the paused session"
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
        if waited == "consent":
            return "wait for the participant's consent on the phone"
        if waited == "before":
            return "wait for the participant's answers before the session (about them)"
        if waited == "questionnaire":
            return f"wait for the participant's questionnaire after interaction {position}"
        return "wait for the participant's final questionnaire"
    if action.get("why") == "ended":
        return "nothing: the session was ended early"
    return "nothing: the session is complete"


def allowed_sentence(actions: list[Action]) -> str:
    return "Allowed now: " + "; or ".join(describe(a) for a in actions) + "."
