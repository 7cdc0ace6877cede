"""How big a study's YAML may become once its anchors and aliases are expanded.

An alias (``*name``) repeats the node its anchor (``&name``) marks. PyYAML composes one
node for both, so a file of a few hundred bytes can stand for billions of values (the
"billion laughs": nine lists of nine aliases of the list before): every later walk over
the document (building the study, locating problems by line, hashing its snapshot) goes
through each repetition, and one such file on the studies API took 62 s and 490 MB before
its 422. :func:`check_expansion` counts the values the document stands for on the
composed node graph, each node once (memoised), before anything is built from it, and
refuses past ``MAX_VALUES`` or a node that contains itself (``&a [*a]``).
"""

from __future__ import annotations

import yaml

# Values (scalars, lists, mappings, keys) of the expanded document. The default study, in
# both its languages, has about 1,500: sixty-fold room for any study a lab writes.
MAX_VALUES = 100_000


class ExpansionError(ValueError):
    """The document is too large once expanded, or refers to itself (one sentence)."""


def _children(node: yaml.Node) -> list[yaml.Node]:
    if isinstance(node, yaml.MappingNode):
        return [part for pair in node.value for part in pair]
    if isinstance(node, yaml.SequenceNode):
        return list(node.value)
    return []


def expanded_size(root: yaml.Node, limit: int = MAX_VALUES) -> int:
    """The number of values ``root`` stands for with every alias written out; raises
    :class:`ExpansionError` beyond ``limit`` or on a cycle. Iterative (no recursion to run
    out of) and linear in the composed nodes, whatever the expansion."""
    sizes: dict[int, int] = {}
    open_nodes: set[int] = set()
    stack: list[tuple[yaml.Node, bool]] = [(root, False)]
    while stack:
        node, children_done = stack.pop()
        key = id(node)
        if children_done:
            open_nodes.discard(key)
            size = 1 + sum(sizes[id(child)] for child in _children(node))
            if size > limit:
                raise ExpansionError(
                    f"the document stands for more than {limit} values once its aliases "
                    "(*name) are expanded: write the repeated parts out, or repeat them less"
                )
            sizes[key] = size
            continue
        if key in sizes:
            continue
        if key in open_nodes:
            raise ExpansionError(
                f"an alias refers to a node that contains it (line {node.start_mark.line + 1})"
            )
        open_nodes.add(key)
        stack.append((node, True))
        stack.extend((child, False) for child in _children(node) if id(child) not in sizes)
    return sizes[id(root)]
