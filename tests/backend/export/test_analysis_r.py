"""analysis.R in the export bundle.

Always: every file it reads is in the bundle with exactly the columns and types the
codebook gives, every column it uses exists (or the script made it), and its brackets and
strings are well formed. When R (with lme4 and ordinal) is installed, the script is also
parsed and run by R on a real export, and its Friedman statistics must equal the Python
analysis's. CI machines have no R: those two tests are skipped there, and say so.
"""

from __future__ import annotations

import re
import shutil
import subprocess
from pathlib import Path

import pytest
from sqlalchemy.orm import Session as DbSession

from chameleons.backend.export.analysis_r import R_TYPES, analysis_script
from chameleons.backend.export.columns import TABLE_NAMES, TableSpec, table_specs
from chameleons.backend.export.service import ExportRequest, export_to_directory
from chameleons.backend.models import Study
from chameleons.experiment.study import load_default_study
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


@pytest.mark.skipif(RSCRIPT is None, reason="R is not installed here (.ci/run installs it)")
def test_r_parses_and_runs_it_and_its_friedman_tests_equal_ours(
    db_session: DbSession, tmp_path: Path
) -> None:
    assert RSCRIPT is not None
    probe = subprocess.run([RSCRIPT, "-e", "library(lme4); library(ordinal)"],
                           capture_output=True, text=True, check=False)  # fmt: skip
    if probe.returncode != 0:
        pytest.skip("R is installed without lme4 or ordinal")
    populate(db_session, 12, seed=4, effects={"copy": 0.8})
    db_session.flush()
    export_to_directory(db_session, ExportRequest(), tmp_path)
    parsed = subprocess.run([RSCRIPT, "-e", f"invisible(parse(file = '{tmp_path}/analysis.R'))"],
                            capture_output=True, text=True, check=False)  # fmt: skip
    assert parsed.returncode == 0, parsed.stderr
    ran = subprocess.run([RSCRIPT, "analysis.R"], cwd=tmp_path, capture_output=True,
                         text=True, check=False, timeout=600)  # fmt: skip
    assert ran.returncode == 0, ran.stderr[-3000:]
    assert (tmp_path / "analysis-plots.pdf").read_bytes()[:5] == b"%PDF-"
    from chameleons.cli.analyze_command import read_scores_csv
    from chameleons.experiment.stats import analyze

    ours = analyze(read_scores_csv(tmp_path / "scores.csv"))
    for measure, result in ours.measures.items():
        match = re.search(rf"^{measure}\s+chi2\(2\) = ([\d.]+)", ran.stdout, re.M)
        assert match is not None, ran.stdout[:2000]
        assert float(match.group(1)) == pytest.approx(result.friedman.chi2, abs=0.005)
    assert "Generalized linear mixed model" in ran.stdout
    assert "Cumulative Link Mixed Model" in ran.stdout
