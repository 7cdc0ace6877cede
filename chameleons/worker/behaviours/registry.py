"""Behaviour registry: built-ins plus whatever labs add, without editing the router.

A lab adds a behaviour either by decorating a :class:`Behaviour` subclass with
``@register_behaviour("name")`` in a module that gets imported, or — without touching this
package — by declaring an entry point in its own package::

    [project.entry-points."chameleons.behaviours"]
    smile = "mylab.behaviours:SmileBehaviour"

The entry point may name a Behaviour subclass (registered under the entry point's name) or a
module whose import registers behaviours with the decorator.
"""

from __future__ import annotations

import importlib
import logging
from collections.abc import Callable, Mapping
from importlib.metadata import entry_points
from typing import Any, TypeVar

from chameleons.worker.behaviours.base import Behaviour, BehaviourContext, BehaviourError
from chameleons.worker.behaviours.params import Declared, Param

ENTRY_POINT_GROUP = "chameleons.behaviours"
_BUILTIN_MODULES = (
    "chameleons.worker.behaviours.still",
    "chameleons.worker.behaviours.copy",
    "chameleons.worker.behaviours.natural",
    "chameleons.worker.behaviours.yoked_copy",
)
_registry: dict[str, type[Behaviour]] = {}
_discovered = False
log = logging.getLogger(__name__)

B = TypeVar("B", bound=type[Behaviour])


def register_behaviour(name: str) -> Callable[[B], B]:
    """Class decorator: make a behaviour available under ``name``."""

    def decorate(cls: B) -> B:
        existing = _registry.get(name)
        if existing is not None and existing is not cls:
            raise BehaviourError(f"behaviour {name!r} is already registered by {existing!r}")
        cls.name = name
        _registry[name] = cls
        return cls

    return decorate


def discover() -> None:
    """Import the built-ins and the ``chameleons.behaviours`` entry points (once)."""
    global _discovered
    if _discovered:
        return
    _discovered = True
    for module in _BUILTIN_MODULES:
        importlib.import_module(module)
    for entry in entry_points(group=ENTRY_POINT_GROUP):
        try:
            loaded = entry.load()
        except Exception:  # a broken plug-in must not take the worker down
            log.exception("could not load behaviour entry point %s", entry.value)
            continue
        if isinstance(loaded, type) and issubclass(loaded, Behaviour):
            register_behaviour(entry.name)(loaded)


def available_behaviours() -> dict[str, type[Behaviour]]:
    discover()
    return dict(_registry)


def create_behaviour(name: str, params: Mapping[str, Any], context: BehaviourContext) -> Behaviour:
    """A new behaviour instance; raises BehaviourError for an unknown name or bad params."""
    behaviours = available_behaviours()
    cls = behaviours.get(name)
    if cls is None:
        known = ", ".join(sorted(behaviours))
        raise BehaviourError(f"unknown behaviour {name!r} (available: {known})")
    try:
        return cls.from_params(context, params)
    except BehaviourError:
        raise
    except (TypeError, ValueError, OSError) as exc:
        raise BehaviourError(f"{name}: {exc}") from exc


def behaviour_parameters() -> dict[str, Mapping[str, Param]]:
    """Every registered behaviour's declared parameters (what a study may set)."""
    # A Declared mapping keeps its check of the combination (copy's coexpress and delay).
    return {name: cls.parameters if isinstance(cls.parameters, Declared) else dict(cls.parameters)
            for name, cls in available_behaviours().items()}  # fmt: skip
