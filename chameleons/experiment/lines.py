"""Where in a YAML file each place of the study document is, for ``file:line`` messages.

Places are the reader's dotted paths (``conditions.copy.params.delay``,
``tasks.lunar.items[3].expert_rank``); a problem whose own place has no line (a missing
key) is located at its nearest parent that has one.
"""

from __future__ import annotations

import re

import yaml

from chameleons.experiment.reader import join

_PLACE = re.compile(r"^(?P<place>[^:\s]*(?:\[\d+\])*): ")


def line_index(text: str) -> dict[str, int]:
    """Place -> 1-based line of its key (mappings) or item (lists); empty when unparseable."""
    try:
        root = yaml.compose(text, Loader=yaml.SafeLoader)
    except yaml.YAMLError:
        return {}
    return node_lines(root)


def node_lines(root: yaml.Node | None) -> dict[str, int]:
    """:func:`line_index` of an already composed document (None: an empty one)."""
    lines: dict[str, int] = {}
    if root is not None:
        _walk(root, "", lines)
    return lines


def _walk(node: yaml.Node, path: str, lines: dict[str, int]) -> None:
    if isinstance(node, yaml.MappingNode):
        for key_node, value_node in node.value:
            place = join(path, str(key_node.value))
            lines.setdefault(place, key_node.start_mark.line + 1)
            _walk(value_node, place, lines)
    elif isinstance(node, yaml.SequenceNode):
        for index, item in enumerate(node.value):
            place = join(path, index)
            lines.setdefault(place, item.start_mark.line + 1)
            _walk(item, place, lines)


def line_of(problem: str, lines: dict[str, int]) -> int | None:
    """The line a ``place: message`` problem belongs to (its place, else a parent's)."""
    match = _PLACE.match(problem)
    if match is None:
        return None
    place = match.group("place")
    while place:
        if place in lines:
            return lines[place]
        place = _parent(place)
    return None


def _parent(place: str) -> str:
    if place.endswith("]"):
        return place[: place.rindex("[")]
    return place.rpartition(".")[0]
