"""Behaviour modules: ``still``, ``natural``, ``copy`` and whatever labs register.

See :mod:`chameleons.worker.behaviours.registry` for adding one.
"""

from chameleons.worker.behaviours.base import (
    NO_INPUT,
    VECTOR_SIZE,
    Behaviour,
    BehaviourContext,
    BehaviourError,
)
from chameleons.worker.behaviours.registry import (
    available_behaviours,
    create_behaviour,
    register_behaviour,
)

__all__ = [
    "NO_INPUT",
    "VECTOR_SIZE",
    "Behaviour",
    "BehaviourContext",
    "BehaviourError",
    "available_behaviours",
    "create_behaviour",
    "register_behaviour",
]
