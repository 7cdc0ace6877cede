"""analysis.R in the export bundle.

Always: every file it reads is in the bundle with exactly the columns and types the
codebook gives, every column it uses exists (or the script made it), and its brackets and
strings are well formed. When R (with lme4 and ordinal) is installed, the script is also
parsed and run by R on real exports (one participant; twelve with an exclusion, a
deviation and a session ended early, in both views), and its numbers must equal the Python
analysis's to the decimals R prints: Friedman chi2, asymptotic and exact permutation p,
Kendall's W, post-hoc V and p, rank-biserial r and median differences, Cronbach's alpha
(all ratings, and per condition with Feldt's interval), and the suggestion mix. Machines
without R skip those tests, and say so.
"""

from __future__ import annotations

import re
import shutil
import subprocess
from pathlib import Path

import pytest
from sqlalchemy import Engine
from sqlalchemy.orm import Session as DbSession

from chameleons.backend.db import build_sessionmaker
from chameleons.backend.export.analysis_r import R_TYPES, analysis_script
from chameleons.backend.export.columns import TABLE_NAMES, TableSpec, table_specs
from chameleons.backend.export.service import ExportRequest, export_to_directory
from chameleons.backend.models import Study
from chameleons.cli.analyze_command import (
    read_answers_beside,
    read_scores_csv,
    read_suggestions_beside,
    study_for_scores,
)
from chameleons.experiment.stats import Analysis, View, analyze
from chameleons.experiment.stats.effect_sizes import BootstrapOptions
from chameleons.experiment.stats.measures import study_measures
from chameleons.experiment.study import load_default_study
from tests.backend.analysis.test_page_from_export import set_up
from tests.support.factories import create_study, populate

RSCRIPT = shutil.which("Rscript")
READ = re.compile(r'(\w+) <- read_table\("([\w.]+)", c\((.*?)\)\)', re.S)
PAIR = re.compile(r'"([^"]+)" = "([^"]+)"')


def script(db: DbSession) -> tuple[str, list[TableSpec]]:
    spec = load_default_study()
    study = create_study(db, spec)
    specs = table_specs(spec)
    return analysis_script(study, spec, specs), specs


def strip_strings_and_comments(text: str) -> str:
    """The code with string contents and comments blanked; raises on an unclosed string."""
    out, i = [], 0
    while i < len(text):
        char = text[i]
        if char == "#":
            while i < len(text) and text[i] != "\n":
                i += 1
            continue
        if char in "\"'":
            end = i + 1
            while end < len(text) and text[end] != char:
                end += 2 if text[end] == "\\" else 1
            if end >= len(text):
                raise AssertionError(f"unclosed string at {text[i : i + 40]!r}")
            out.append('""')
            i = end + 1
            continue
        out.append(char)
        i += 1
    return "".join(out)


def test_every_file_and_column_it_names_exists(db_session: DbSession) -> None:
    text, specs = script(db_session)
    tables = {t.name: t for t in specs}
    reads = READ.findall(text)
    assert {name for name, _, _ in reads} == {"scores", "suggestions", "interactions",
                                              "questionnaire"}  # fmt: skip
    available: dict[str, set[str]] = {}
    for variable, file, body in reads:
        table = tables[file.removesuffix(".csv")]
        assert file.removesuffix(".csv") in TABLE_NAMES
        pairs = PAIR.findall(body)
        assert [name for name, _ in pairs] == table.column_names, file
        assert [kind for _, kind in pairs] == [R_TYPES[c.type] for c in table.columns], file
        available[variable] = set(table.column_names)
    code = strip_strings_and_comments(text)
    made = set(re.findall(r"\$(\w+) <-", code))  # columns the script adds
    everything = set().union(*available.values()) | made
    for frame, column in re.findall(r"\b(\w+)\$(\w+)", code):
        if frame in available:
            assert column in available[frame] | made, f"{frame}${column}"
    # Columns named in strings: column selections, merge keys, model terms and outcomes.
    selections = re.findall(r"(?:\[, |by = |terms <- )c\(([^()]*)\)", text)
    assert len(selections) >= 5
    for selection in selections:
        for name in re.findall(r'"(\w+)"', selection):
            assert name in everything, name
    for outcome in re.findall(r'"(\w+) ~', text):
        assert outcome in everything, outcome
    measures = re.search(r"^measures <- c\((.*)\)$", text, re.M)
    assert measures is not None
    for measure in re.findall(r'"(\w+)"', measures.group(1)):
        assert measure in available["scores"]


def test_brackets_and_strings_are_well_formed(db_session: DbSession) -> None:
    text, _ = script(db_session)
    code = strip_strings_and_comments(text)
    stack: list[str] = []
    pairs = {")": "(", "]": "[", "}": "{"}
    for line_number, line in enumerate(code.splitlines(), start=1):
        for char in line:
            if char in "([{":
                stack.append(char)
            elif char in pairs:
                assert stack, f"line {line_number}: stray {char}"
                assert stack.pop() == pairs[char], f"line {line_number}: mismatched {char}"
    assert not stack, f"unclosed {stack}"
    assert "True" not in code.replace("TRUE", "")  # no Python booleans
    assert "None" not in code
    # The checker itself fails on what it must catch.
    with pytest.raises(AssertionError):
        strip_strings_and_comments('x <- "open')


def test_the_study_name_cannot_break_out_of_its_comment(db_session: DbSession) -> None:
    spec = load_default_study()
    study = Study(name='evil"\nsystem("rm -rf /")', config=spec.config, config_hash="x" * 64)
    text = analysis_script(study, spec, table_specs(spec))
    assert 'system("rm -rf /")' in text.splitlines()[1]  # still inside the comment line
    assert text.splitlines()[1].startswith("#")



needs_r = pytest.mark.skipif(RSCRIPT is None, reason="R is not installed here (.ci/run has it)")
# The tests compare no bootstrap bound (R's generator is not NumPy's): fewer resamples.
FEWER_RESAMPLES = ("bootstrap_resamples <- 2000", "bootstrap_resamples <- 200")


def run_r(folder: Path, *args: str) -> str:
    assert RSCRIPT is not None
    probe = subprocess.run([RSCRIPT, "-e", "library(lme4); library(ordinal)"],
                           capture_output=True, text=True, check=False)  # fmt: skip
    if probe.returncode != 0:
        pytest.skip("R is installed without lme4 or ordinal")
    script = folder / "analysis.R"
    text = script.read_text()
    assert FEWER_RESAMPLES[0] in text
    script.write_text(text.replace(*FEWER_RESAMPLES))
    parsed = subprocess.run([RSCRIPT, "-e", f"invisible(parse(file = '{script}'))"],
                            capture_output=True, text=True, check=False)  # fmt: skip
    assert parsed.returncode == 0, parsed.stderr
    ran = subprocess.run([RSCRIPT, "analysis.R", ".", *args], cwd=folder, capture_output=True,
                         text=True, check=False, timeout=1200)  # fmt: skip
    assert ran.returncode == 0, ran.stderr[-3000:]
    assert (folder / "analysis-plots.pdf").read_bytes()[:5] == b"%PDF-"
    assert not re.search(r"p = 0\.0000|p = <", ran.stdout)  # p < 0.0001 is written so
    return ran.stdout


def python_analysis(folder: Path, view: View) -> Analysis:
    """The Python analysis of the same files, as `chameleons analyze --scores` reads them."""
    scores = folder / "scores.csv"
    spec, _ = study_for_scores(scores, None)
    design = study_measures(spec)
    return analyze(
        read_scores_csv(scores), measures=design.measures, condition_order=design.order,
        conditions=design.conditions, scales=design.scales, view=view,
        bootstrap=BootstrapOptions(200), models=False, suggestions=read_suggestions_beside(scores),
        questionnaires=spec.questionnaires, answers=read_answers_beside(scores),
    )  # fmt: skip


def same(printed: str, value: float | None, decimals: int) -> bool:
    """``printed`` (R's text) is ``value`` rounded to ``decimals``: within half a unit of
    the last decimal, the precision the Friedman comparison always used."""
    printed = printed.strip().removeprefix("=").strip()
    if value is None:
        return printed == "undefined"
    if printed.startswith("<"):
        return value < float(printed.removeprefix("<"))
    return bool(abs(float(printed) - value) <= 0.5 * 10**-decimals + 1e-12)


P = r"(= [\d.]+|< 0\.0001|undefined)"


def compare(stdout: str, ours: Analysis) -> int:
    """Every number R prints that the Python analysis has; returns how many were compared."""
    compared = 0

    def check(printed: str, value: float | None, decimals: int, what: str) -> None:
        nonlocal compared
        assert same(printed, value, decimals), f"{what}: R {printed}, Python {value}"
        compared += 1

    for measure, result in ours.measures.items():
        line = re.search(
            rf"^{measure}\s+chi2\(2\) = ([\d.]+), p {P}, Bonferroni p {P}, Kendall's W = "
            rf"([\d.]+), n = (\d+); permutation p \(exact\) {P}, Bonferroni p {P}$",
            stdout, re.M,
        )  # fmt: skip
        assert line is not None, f"{measure}: {stdout[:3000]}"
        f, perm = result.friedman, result.permutation
        assert perm is not None
        assert int(line.group(5)) == f.n
        for index, value, decimals in [
            (1, f.chi2, 2), (2, f.p, 4), (3, result.p_bonferroni, 4), (4, f.kendall_w, 3),
            (6, perm.p, 4), (7, result.permutation_p_bonferroni, 4),
        ]:  # fmt: skip
            check(line.group(index), value, decimals, f"{measure} group {index}")
        posthoc = re.findall(
            rf"^  post-hoc {measure} (\w+) vs (\w+): V = ([\d.]+), p {P}, Bonferroni p {P}$",
            stdout, re.M,
        )  # fmt: skip
        assert [(a, b) for a, b, *_ in posthoc] == [(t.a, t.b) for t in result.posthoc]
        for (_, _, v, p, p_b), test in zip(posthoc, result.posthoc, strict=True):
            check(v, test.v, 1, "V")
            check(p, test.p, 4, "post-hoc p")
            check(p_b, test.p_bonferroni, 4, "post-hoc Bonferroni p")
        effects = result.effect_sizes
        assert effects is not None
        for pair in effects.pairs:
            effect = re.search(
                rf"^  effect {measure} {pair.a} - {pair.b}: rank-biserial r = (-?[\d.]+|undefined)"
                rf".*, median difference = (-?[\d.]+|undefined) ", stdout, re.M,
            )  # fmt: skip
            assert effect is not None, f"{measure} {pair.a} - {pair.b}"
            check(effect.group(1), pair.rank_biserial.estimate, 3, "r")
            check(effect.group(2), pair.median_difference.estimate, 3, "median difference")
    for scale in ours.reliability:
        pooled = re.search(rf"^{scale.scale}\s+alpha = (-?[\d.]+|undefined), .*; n = (\d+) "
                           rf"ratings from (\d+) participants", stdout, re.M)  # fmt: skip
        assert pooled is not None, scale.scale
        check(pooled.group(1), scale.alpha, 3, f"alpha {scale.scale}")
        assert (int(pooled.group(2)), int(pooled.group(3))) == (scale.n, scale.participants)
        for per in scale.by_condition:
            line = re.search(
                rf"^  alpha {scale.scale} {per.condition}: (-?[\d.]+|undefined), 95% CI "
                rf"\(Feldt\) \[(-?[\d.]+|undefined), (-?[\d.]+|undefined)\], n = (\d+)$",
                stdout, re.M,
            )  # fmt: skip
            assert line is not None, (scale.scale, per.condition)
            check(line.group(1), per.alpha, 3, "alpha per condition")
            check(line.group(2), per.ci_low, 3, "Feldt low")
            check(line.group(3), per.ci_high, 3, "Feldt high")
            assert int(line.group(4)) == per.n
    mix = ours.suggestion_mix
    assert mix is not None
    for condition in mix.conditions:
        line = re.search(rf"^  mix {condition.condition}: (\d+) suggestions: (\d+) optimal, "
                         rf"(\d+) random.*, (\d+) moved down$", stdout, re.M)  # fmt: skip
        assert line is not None, condition.condition
        assert tuple(map(int, line.groups())) == (
            condition.total, condition.optimal, condition.random, condition.down,
        )  # fmt: skip
        compared += 4
    line = re.search(rf"^  random suggestions per participant: Friedman chi2\(2\) = ([\d.]+), "
                     rf"p {P}, permutation p \(exact\) {P}, n = (\d+)$", stdout, re.M)  # fmt: skip
    assert line is not None
    assert mix.permutation is not None
    check(line.group(1), mix.friedman.chi2, 2, "mix chi2")
    check(line.group(2), mix.friedman.p, 4, "mix p")
    check(line.group(3), mix.permutation.p, 4, "mix exact p")
    assert int(line.group(4)) == mix.participants
    return compared


@needs_r
def test_r_runs_on_a_one_participant_export(db_session: DbSession, tmp_path: Path) -> None:
    """R's friedman.test fails on one participant (dim(X) must have a positive length):
    the script computes that case itself and says the numbers mean nothing; the models say
    why they are not fitted; the plots are drawn."""
    populate(db_session, 1, seed=2)
    db_session.flush()
    export_to_directory(db_session, ExportRequest(), tmp_path)
    stdout = run_r(tmp_path)
    assert "accepted     chi2(2) = " in stdout
    assert "only 1 participant: Kendall's W is 1 (or undefined)" in stdout
    assert "acceptance model not available: needs at least two participants" in stdout
    assert compare(stdout, python_analysis(tmp_path, "as_planned")) > 30


@needs_r
@pytest.mark.parametrize("view", ["as_planned", "as_run"])
def test_r_agrees_with_python_in_both_views(engine: Engine, tmp_path: Path, view: View) -> None:
    """Twelve participants, copy clearly better: P003 excluded, P007's second interaction
    ran the first's condition (a deviation), P012 ended early during interaction 3."""
    study_id = set_up(engine, {"copy": 0.8})
    with build_sessionmaker(engine)() as db:
        export_to_directory(db, ExportRequest(study_id=study_id), tmp_path)
    stdout = run_r(tmp_path, view)
    ours = python_analysis(tmp_path, view)
    assert "Excluded: P003" in stdout
    assert ("Left out for a deviation from the plan: P007" in stdout) == (view == "as_run")
    assert any(r.posthoc for r in ours.measures.values())  # the post-hoc lines are compared
    assert compare(stdout, ours) > 100
    assert "Generalized linear mixed model" in stdout
    assert "Acceptance adjusted for suggestion kind (secondary: the kind is a mediator)" in stdout
    assert "Cumulative Link Mixed Model" in stdout
