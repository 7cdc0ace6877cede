"""The console's prompt layout as a pure function of a catalogue and the interaction."""

from __future__ import annotations

from pathlib import Path

from chameleons.backend.wizard.layout import InteractionFacts, sections, suggestion_groups
from chameleons.prompts import ActorProfile, Catalogue, Prompt, Stage


def prompt(
    id: str, stage: Stage, group: str | None = None, text: str = "", **fields: object
) -> Prompt:
    text = text or f"Text of {id}."
    return Prompt(id=id, stage=stage, group=group or id, text=text, **fields)  # type: ignore[arg-type]


ITEMS = [f"item{n}" for n in range(1, 12)]
CATALOGUE = Catalogue(
    "a1",
    Path("/nonexistent"),
    ActorProfile("a1", "Actor one"),
    [
        prompt("hello_nova", Stage.INTRO, robot_name="Nova"),
        prompt("hello_kai", Stage.INTRO, robot_name="Kai"),
        prompt("hello_any", Stage.INTRO),
        prompt("moon", Stage.SCENARIO, task="lunar"),
        prompt("sand", Stage.SCENARIO, task="desert"),
        prompt("wave", Stage.TRANSITION),
        prompt("ack_yes", Stage.ACKNOWLEDGEMENT),
        prompt("ack_yes_2", Stage.ACKNOWLEDGEMENT, group="ack_yes"),
        prompt("ack_wow", Stage.ACKNOWLEDGEMENT, text="Wow, that is a remarkable thought."),
        prompt("ack_wonderful", Stage.ACKNOWLEDGEMENT, text="Wonderful, what a lovely idea."),
        *[prompt(f"d_{i}", Stage.ITEM_DESCRIPTION, task="lunar", item=i) for i in ITEMS],
        prompt("up_item1", Stage.SUGGESTION, task="lunar", item="item1"),
        prompt("item1_first", Stage.SUGGESTION, task="lunar", item="item1"),
        prompt("item1_over_2", Stage.SUGGESTION, task="lunar", item="item1", other_item="item2"),
        prompt("item1_over_9", Stage.SUGGESTION, task="lunar", item="item1", other_item="item9"),
    ],
)


def facts(items: list[str], robot: str = "Nova") -> InteractionFacts:
    return InteractionFacts("lunar", items, {i: i.upper() for i in items}, robot)


def by_id(result: list[dict[str, object]]) -> dict[str, list[dict[str, object]]]:
    return {str(s["id"]): s["buttons"] for s in result}  # type: ignore[misc]


def test_script_keeps_the_robot_s_and_generic_intros_and_the_task_s_scenario() -> None:
    script = by_id(sections(CATALOGUE, facts(ITEMS[:3])))["script"]
    assert [b["group"] for b in script] == ["hello_nova", "hello_any", "moon", "wave"]
    assert script[0]["label"] == "Introduce (Nova)"


def test_letters_go_to_the_preferred_key_else_the_first_free_letter_of_the_label() -> None:
    result = by_id(sections(CATALOGUE, facts(ITEMS[:3])))
    keys = {b["group"]: b["shortcut"]["label"] for b in result["script"] + result["replies"]}  # type: ignore[index]
    assert keys["hello_nova"] == "I"
    assert keys["hello_any"] == "N"  # I is taken; "Introduce" -> N
    assert keys["moon"] == "E"
    assert keys["ack_yes"] == "Y"
    assert keys["wave"] == "W"
    assert keys["ack_wow"] == "O"  # a long text is labelled by its group: "Wow"; W is taken
    assert keys["ack_wonderful"] == "R"  # W, O, N, E are taken and D is reserved
    assert all(k not in {"A", "D", "U", "M"} for k in keys.values())


def test_items_beyond_nine_have_no_digit() -> None:
    items = by_id(sections(CATALOGUE, facts(ITEMS)))["items"]
    assert [b["position"] for b in items] == list(range(1, 12))
    assert items[8]["shortcut"]["label"] == "9"  # type: ignore[index]
    assert items[9]["shortcut"] is None


def test_suggestions_about_items_not_shown_are_left_out() -> None:
    shown = by_id(sections(CATALOGUE, facts(ITEMS[:3])))["suggestions"]
    assert [b["group"] for b in shown] == ["up_item1", "item1_first", "item1_over_2"]
    assert [b["kind"] for b in shown] == ["move_up", "make_first", "above"]
    assert shown[2]["label"] == "ITEM1: above ITEM2"


def test_suggestion_groups_prefer_above_then_first_then_move_up() -> None:
    ranking = ["item2", "item3", "item1"]
    assert suggestion_groups(CATALOGUE, "lunar", "item1", 1, ranking) == [
        "item1_over_2",
        "item1_first",
        "up_item1",
    ]
    assert suggestion_groups(CATALOGUE, "lunar", "item1", 2, ranking) == ["up_item1"]
    assert suggestion_groups(CATALOGUE, "desert", "item1", 1, ranking) == []
