"""What each suggestion rule does to the suggestions, measured by simulation.

docs/science.md ("The suggestion rule") quotes these numbers; run
``python -m chameleons.experiment.suggestion_audit`` to reproduce them. Each simulated
interaction has ``items`` items in a uniformly random initial ranking, and the robot makes
``suggestions`` suggestions under the rule, each accepted with probability
``accept_probability`` (applied to the ranking) or declined (remembered), as the session
flow does. Counted per rule:

- ``random_share``: suggestions that were the random fallback;
- ``fallback_while_misplaced``: of the random ones, those made while an item the
  participant had not declined was still out of its place in the expert order (the paper
  says the fallback is for when there is none);
- ``optimal_down``: of the optimal ones, those moving the item down;
- ``optimal_no_gain``: of the optimal ones, those that do not lower the error score;
- ``mean_final_error``: the error score after the last suggestion, per interaction.

The second table is why the acceptance model leaves the kind out: under every rule the
share of random suggestions depends on how often the participant accepts (under
expert_place and best_move it grows: accepting reaches the expert order sooner; under
up_only it shrinks: declines block the moves up), so a condition whose participants accept
more gets a different mix of suggestions (the kind is a mediator).
"""

from __future__ import annotations

import random
from dataclasses import asdict, dataclass

from chameleons.experiment.suggestions import (
    RULES,
    Rule,
    apply_suggestion,
    error_score,
    misplaced,
    next_suggestion,
)


@dataclass(frozen=True)
class RuleAudit:
    rule: str
    interactions: int
    suggestions: int
    random_share: float
    fallback_while_misplaced: float
    optimal_down: float
    optimal_no_gain: float
    mean_final_error: float

    def to_dict(self) -> dict[str, object]:
        return asdict(self)


def audit(
    rule: Rule,
    interactions: int = 20_000,
    *,
    items: int = 5,
    suggestions: int = 3,
    accept_probability: float = 0.5,
    seed: int = 1,
) -> RuleAudit:
    rng = random.Random(f"{seed}/{rule}")
    expert = [f"item{i}" for i in range(items)]
    made = randoms = while_misplaced = optimal = down = no_gain = final_error = 0
    for _ in range(interactions):
        ranking = rng.sample(expert, items)
        declined: set[str] = set()
        for _ in range(suggestions):
            suggestion = next_suggestion(ranking, expert, declined, rng, rule)
            made += 1
            after = apply_suggestion(ranking, suggestion)
            if suggestion.kind == "random":
                randoms += 1
                while_misplaced += bool(misplaced(ranking, expert, declined))
            else:
                optimal += 1
                down += suggestion.direction == "down"
                no_gain += error_score(after, expert) >= error_score(ranking, expert)
            if rng.random() < accept_probability:
                ranking = after
            else:
                declined.add(suggestion.item)
        final_error += error_score(ranking, expert)
    return RuleAudit(
        rule,
        interactions,
        made,
        randoms / made if made else 0.0,
        while_misplaced / randoms if randoms else 0.0,
        down / optimal if optimal else 0.0,
        no_gain / optimal if optimal else 0.0,
        final_error / interactions if interactions else 0.0,
    )


def main() -> None:  # pragma: no cover - a report for the docs
    print("rule          random  fallback while misplaced  optimal down  "
          "optimal no gain  final error")  # fmt: skip
    for rule in RULES:
        a = audit(rule)
        print(
            f"{a.rule:<13} {a.random_share:6.1%}  {a.fallback_while_misplaced:24.1%}  "
            f"{a.optimal_down:12.1%}  {a.optimal_no_gain:15.1%}  {a.mean_final_error:11.2f}"
        )


def random_share_by_acceptance(
    rule: Rule, probabilities: tuple[float, ...] = (0.3, 0.5, 0.7), interactions: int = 20_000
) -> dict[float, float]:
    return {
        p: audit(rule, interactions, accept_probability=p).random_share for p in probabilities
    }


def main_mediator() -> None:  # pragma: no cover - a report for the docs
    print("\nrandom share by acceptance probability")
    for rule in RULES:
        shares = random_share_by_acceptance(rule)
        print(f"{rule:<13} " + "  ".join(f"p={p:.1f}: {v:5.1%}" for p, v in shares.items()))


if __name__ == "__main__":  # pragma: no cover
    main()
    main_mediator()
