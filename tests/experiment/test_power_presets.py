"""The design-space templates' power presets (issue 31): the sample sizes are what the
paired t-test's power says (checked against the noncentral t directly, not only through
statsmodels), the Wilcoxon and balance adjustments are applied as stated, docs/
design-space.md shows exactly these figures, and each template's section there cites the
sources its preset lists. ``chameleons study power`` prints them."""

from __future__ import annotations

import math
import re
from pathlib import Path

import pytest
from click.testing import CliRunner
from scipy import stats
from statsmodels.stats.power import TTestPower

from chameleons.cli.main import cli
from chameleons.experiment import power_presets as presets
from chameleons.experiment.blocks import balance_period
from chameleons.experiment.study import load_study
from chameleons.experiment.templates import study_templates

DOC = Path(__file__).resolve().parents[2] / "docs" / "design-space.md"


def noncentral_power(d_z: float, n: float, alpha: float) -> float:
    """Two-sided paired t-test power from the noncentral t distribution."""
    df = n - 1
    critical = stats.t.ppf(1 - alpha / 2, df)
    shift = d_z * math.sqrt(n)
    return float(stats.nct.sf(critical, df, shift) + stats.nct.cdf(-critical, df, shift))


def test_the_textbook_anchor() -> None:
    """d_z = 0.5 at alpha 0.05: 34 pairs for 80 % power (G*Power's figure, Cohen 1988)."""
    assert math.ceil(presets.paired_n(0.5, 0.05)) == 34
    assert noncentral_power(0.5, 34, 0.05) >= 0.8 > noncentral_power(0.5, 33, 0.05)


@pytest.mark.parametrize("template", presets.TEMPLATES, ids=lambda t: t.template)
def test_each_templates_preset_is_what_the_power_of_its_test_says(
    template: presets.TemplatePower,
) -> None:
    study = load_study(study_templates()[template.template])
    assert tuple(study.condition_ids) == template.conditions
    assert set(template.primary) <= set(template.conditions)
    assert balance_period(study) == template.balance_period == 12
    assert template.alpha == pytest.approx(0.05 / 3)
    for d in presets.CONVENTIONS:
        n = presets.planned_n(d, template)
        assert n % 12 == 0
        pairs = presets.paired_n(d, template.alpha)
        assert TTestPower().power(d, pairs, template.alpha) == pytest.approx(0.8, abs=1e-6)
        assert noncentral_power(d, pairs, template.alpha) == pytest.approx(0.8, abs=1e-3)
        # Enough for the Wilcoxon at its worst efficiency; 12 fewer would not be.
        assert noncentral_power(d, n * presets.WILCOXON_ARE, template.alpha) >= 0.8
        assert noncentral_power(d, (n - 12) * presets.WILCOXON_ARE, template.alpha) < 0.8
    for n in presets.SIZES:
        d = presets.detectable(n, template)
        assert noncentral_power(d, n * presets.WILCOXON_ARE, template.alpha) == pytest.approx(
            0.8, abs=1e-3
        )


def _table(section: str, header: str) -> dict[str, str]:
    """First column -> last column of the Markdown table under ``header``."""
    lines = section[section.index(header) :].splitlines()[2:]
    rows = {}
    for line in lines:
        if not line.startswith("|"):
            break
        cells = [c.strip() for c in line.strip("|").split("|")]
        rows[cells[0]] = cells[-1]
    return rows


def test_the_docs_show_exactly_the_computed_presets() -> None:
    text = DOC.read_text(encoding="utf-8")
    section = text[text.index("### Power presets") :]
    first = presets.TEMPLATES[0]
    rows = presets.preset_rows(first)
    for other in presets.TEMPLATES[1:]:  # the same design shape: the same figures
        assert presets.preset_rows(other) == rows
    needed = _table(section, "| d_z (convention) | Participants needed |")
    assert needed == {f"{d:g}": str(presets.planned_n(d, first)) for d in presets.CONVENTIONS}
    detected = _table(section, "| Participants | Smallest d_z detected (80 % power) |")
    assert detected == {str(n): f"{presets.detectable(n, first):.2f}" for n in presets.SIZES}
    studies = _table(section, "| Study | Design | Detectable |")
    assert studies == {
        ref.source: f"{'d_z' if ref.within else 'd'} >= {ref.detectable():.2f}"
        for ref in presets.REFERENCES
    }


@pytest.mark.parametrize("template", presets.TEMPLATES, ids=lambda t: t.template)
def test_each_templates_section_cites_its_sources(template: presets.TemplatePower) -> None:
    text = DOC.read_text(encoding="utf-8")
    match = re.search(rf"^### `{template.template}`\n(.*?)(?=^### )", text, re.S | re.M)
    assert match is not None, f"no section for {template.template}"
    section = match.group(1)
    references = text[text.index("### References") :]
    for source in template.sources:
        assert source in section, (template.template, source)
        first_author, year = source.split(" ")[0].rstrip(","), source[-5:-1]
        assert re.search(rf"^- {first_author}, .*?\({year}\)", references, re.M), source
    if not template.sources:
        assert "Not taken from a paper" in section


def test_study_power_prints_the_presets() -> None:
    result = CliRunner().invoke(cli, ["study", "power", "partial_full"])
    assert result.exit_code == 0, result.output
    assert "primary contrast full vs nods" in result.output
    assert "d_z = 0.5: 60 participants" in result.output
    assert "N = 12: d_z >= 1.19" in result.output
    assert "Hale & Hamilton (2016), Study 1: d_z >= 0.40" in result.output
    wrong = CliRunner().invoke(cli, ["study", "power", "nope"])
    assert wrong.exit_code == 2
    assert "no preset for 'nope'" in wrong.output
