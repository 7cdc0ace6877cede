"""A power simulation as a Markdown table (CLI text, the PI page's download, the
preregistration), and the paper's pilot figures as default assumptions."""

from __future__ import annotations

from typing import Any

from chameleons.experiment.model import Study
from chameleons.experiment.stats.power import TEST_LABELS, TESTS, Assumptions
from chameleons.experiment.stats.rounding import fmt

# The paper's Table I as a pilot: mean accepted suggestions 1.4 / 1.5 / 1.6 of 3, and
# credibility 4.7 / 4.8 / 4.7 (SD about 1.0, split evenly between participants and noise).
PAPER_ACCEPTANCE = {"natural": 1.4 / 3, "copy": 1.5 / 3, "still": 1.6 / 3}
PAPER_SCORES = {"natural": 4.7, "copy": 4.8, "still": 4.7}


def pilot_assumptions(study: Study) -> Assumptions | None:
    """The paper's pilot effects when the study has exactly the paper's conditions."""
    if set(study.condition_ids) != set(PAPER_ACCEPTANCE):
        return None
    return Assumptions(
        acceptance={c: round(PAPER_ACCEPTANCE[c], 4) for c in study.condition_ids},
        scores={c: PAPER_SCORES[c] for c in study.condition_ids},
    )


def estimate_text(cell: dict[str, float | None]) -> str:
    if cell["power"] is None or cell["se"] is None:
        return "not simulated"
    return f"{fmt(cell['power'], 2)} ± {fmt(cell['se'], 2)}"


def power_markdown(result: dict[str, Any], labels: dict[str, str] | None = None) -> str:
    """``result``: :meth:`PowerResult.to_dict` (also as read back from ``--format json``)."""
    names = labels or {}
    a, s, design = result["assumptions"], result["settings"], result["design"]
    reference = names.get(design["reference"], design["reference"])
    lines = [
        "| N | " + " | ".join(TEST_LABELS[t] for t in TESTS) + " |",
        "|---:|" + "---:|" * len(TESTS),
    ]
    for row in result["rows"]:
        lines.append(f"| {row['n']} | " + " | ".join(estimate_text(row[t]) for t in TESTS) + " |")
    largest = max(s["sample_sizes"])
    needed = [
        f"- {TEST_LABELS[t]}: "
        + (f"N = {result['needed'][t]}" if result["needed"][t] else f"more than {largest}")
        for t in TESTS
    ]
    low, high = a["scale"]
    return "\n".join(
        [
            "Assumed effects (per condition):",
            "",
            "| condition | P(accept a suggestion), typical participant | mean score |",
            "|---|---:|---:|",
            *(
                f"| {names.get(c, c)} | {a['acceptance'][c]:.3f} | {a['scores'][c]:.2f} |"
                for c in design["conditions"]
            ),
            "",
            f"Participants differ: SD {a['acceptance_sd']:g} on the logit scale of acceptance; "
            f"scores SD {a['score_sd_between']:g} between and {a['score_sd_within']:g} within "
            f"participants, on the scale {low:g}-{high:g}. "
            f"{design['suggestions_per_interaction']} suggestions per interaction; "
            f"the models compare with {reference}.",
            "",
            f"Power (± Monte Carlo SE; {s['replicates']} simulated studies per N, "
            f"{s['model_replicates']} for the acceptance model; seed {s['seed']}; "
            f"alpha {s['alpha']:g} / {s['tests']} tests):",
            "",
            *lines,
            "",
            f"N needed for {s['target']:.0%} power:",
            "",
            *needed,
            "",
            *(f"Note: {n}" for n in result["notes"]),
        ]
    )
