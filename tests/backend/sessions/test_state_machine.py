"""Every illegal transition answers 409 with why and what is allowed now; nothing changes."""

from __future__ import annotations

import random

from tests.backend.sessions.conftest import refused, to_negotiation
from tests.support.bots import ParticipantBot, WizardBot


def test_advancing_before_start_is_refused(wizard: WizardBot, phone: ParticipantBot) -> None:
    message = refused(lambda: wizard.advance(1, "discussion"), 409)
    assert message == (
        "The session has not started yet. Allowed now: wait for the participant's consent on "
        "the phone."
    )
    phone.consent()
    message = refused(lambda: wizard.advance(1, "discussion"), 409)
    assert message.endswith("Allowed now: wait for the participant's answers before the "
                            "session (about them).")  # fmt: skip
    phone.answer_questionnaires(-1, random.Random(1))
    message = refused(lambda: wizard.advance(1, "discussion"), 409)
    assert message == "The session has not started yet. Allowed now: start the session."
    assert wizard.refresh()["interactions"][0]["state"] == "pending"


def test_starting_twice_is_refused(wizard: WizardBot) -> None:
    wizard.start()
    message = refused(wizard.start, 409)
    assert "already started" in message
    assert message.endswith("Allowed now: move interaction 1 to discussion.")


def test_skipping_a_step_is_refused(wizard: WizardBot) -> None:
    wizard.start()
    message = refused(lambda: wizard.advance(1, "ranking"), 409)
    assert message.startswith("Interaction 1 is in pending; it cannot move to ranking.")
    assert "Allowed now: move interaction 1 to discussion." in message


def test_repeating_a_step_is_refused(wizard: WizardBot) -> None:
    wizard.start()
    wizard.advance(1, "discussion")
    message = refused(lambda: wizard.advance(1, "discussion"), 409)
    assert message.startswith("Interaction 1 is already in discussion.")


def test_an_unknown_step_is_bad_input(wizard: WizardBot) -> None:
    wizard.start()
    assert "not a step" in refused(lambda: wizard.advance(1, "done"), 422)
    assert "not a step" in refused(lambda: wizard.advance(1, "dancing"), 422)
    assert "no interaction 4" in refused(lambda: wizard.advance(4, "discussion"), 422)


def test_a_later_interaction_cannot_start_early(wizard: WizardBot) -> None:
    wizard.start()
    message = refused(lambda: wizard.advance(2, "discussion"), 409)
    assert message.startswith("Interaction 2 cannot start before interaction 1 is done")


def test_negotiation_needs_the_participants_ranking(wizard: WizardBot) -> None:
    wizard.start()
    wizard.advance(1, "discussion")
    wizard.advance(1, "ranking")
    message = refused(lambda: wizard.advance(1, "negotiation"), 409)
    assert message == (
        "The participant has not submitted the ranking of interaction 1 yet. "
        "Allowed now: wait for the participant's ranking in interaction 1."
    )


def test_questionnaire_needs_every_suggestion_decided(
    wizard: WizardBot, phone: ParticipantBot
) -> None:
    to_negotiation(wizard, phone)
    wizard.decide(1, 1, True)
    message = refused(lambda: wizard.advance(1, "questionnaire"), 409)
    assert message.startswith("Only 1 of the 3 suggestions of interaction 1 are decided.")
    assert "accept or decline suggestion 2 of interaction 1" in message


def test_the_wizard_cannot_finish_the_participants_questionnaire(
    wizard: WizardBot, phone: ParticipantBot
) -> None:
    to_negotiation(wizard, phone)
    wizard.negotiate(1, lambda _s: False)
    wizard.advance(1, "questionnaire")
    message = refused(lambda: wizard.advance(2, "discussion"), 409)
    assert "cannot start before interaction 1 is done (it is in questionnaire)" in message
    assert message.endswith(
        "Allowed now: wait for the participant's questionnaire after interaction 1."
    )


def test_a_finished_interaction_cannot_move_again(wizard: WizardBot, phone: ParticipantBot) -> None:
    import random

    to_negotiation(wizard, phone)
    wizard.negotiate(1, lambda _s: True)
    wizard.advance(1, "questionnaire")
    phone.answer_questionnaires(1, random.Random(3))
    wizard.advance(2, "discussion")
    message = refused(lambda: wizard.advance(1, "ranking"), 409)
    assert message.startswith("Interaction 1 is over (done).")


def test_a_complete_session_refuses_every_step(client: object, pi: object, study_id: int) -> None:
    import random

    from tests.support.bots import run_session

    result = run_session(pi, client, study_id, random.Random(5))  # type: ignore[arg-type]
    wizard = WizardBot(pi, result.session_id, result.snapshot)  # type: ignore[arg-type]
    assert "the session is complete" in refused(lambda: wizard.advance(3, "questionnaire"), 409)
    assert "already started" in refused(wizard.start, 409)
    assert "interactions are over" in refused(lambda: wizard.switch_condition("copy"), 409)
    assert refused(lambda: wizard.decide(3, 1, True), 409).endswith(
        "Allowed now: nothing: the session is complete."
    )
