"""The models and effect sizes of a study's analysis, checked by refitting them with
statsmodels on the exported CSV files (read and joined by pandas here, not by our code),
and shown on the analysis page."""

from __future__ import annotations

from pathlib import Path

import pandas as pd
import pytest
import statsmodels.api as sm
import statsmodels.formula.api as smf
from fastapi.testclient import TestClient
from sqlalchemy import Engine
from sqlalchemy.orm import Session as DbSession

from chameleons.backend.analysis.cache import analyses
from chameleons.backend.db import build_sessionmaker, session_scope
from chameleons.backend.export.service import ExportRequest, export_to_directory
from tests.backend.test_auth import add_user, login
from tests.support.factories import populate


def refit_acceptance(export: Path, by_kind: bool) -> sm.GEE:
    """The total effect (no kind), or with ``by_kind`` the secondary kind-adjusted model."""
    suggestions = pd.read_csv(export / "suggestions.csv")
    interactions = pd.read_csv(export / "interactions.csv")
    data = suggestions.merge(
        interactions[["participant", "session", "position", "item_set"]],
        on=["participant", "session", "position"],
        validate="many_to_one",
    )
    data["accepted"] = data["accepted"].astype(float)
    formula = "accepted ~ C(condition, Treatment('still')) + C(position) + C(item_set)" + (
        " + C(kind, Treatment('optimal'))" if by_kind and data["kind"].nunique() > 1 else ""
    )
    return smf.gee(
        formula,
        "participant",
        data,
        family=sm.families.Binomial(),
        cov_struct=sm.cov_struct.Exchangeable(),
    ).fit(cov_type="bias_reduced")


def test_models_refit_on_the_exported_csv(
    db_session: DbSession, client: TestClient, engine: Engine, tmp_path: Path
) -> None:
    populate(db_session, 12, seed=5, effects={"copy": 0.6})
    db_session.commit()
    export_to_directory(db_session, ExportRequest(), tmp_path)
    add_user(engine, "pia", "correct horse", "pi")
    login(client, "pia", "correct horse")
    analyses.clear()
    api = client.get("/api/pi/analysis").json()["analysis"]
    models = api["models"]

    for model, by_kind in (("acceptance", False), ("acceptance_by_kind", True)):
        gee = refit_acceptance(tmp_path, by_kind)
        ours = {(c["term"], c["level"]): c for c in models[model]["coefficients"]}
        assert len(ours) == len(gee.params)
        for name, estimate in gee.params.items():
            if name == "Intercept":
                key = ("Intercept", "")
            else:
                key = (name.split("(")[1].split(",")[0].split(")")[0], name.split("[T.")[1][:-1])
            assert ours[key]["estimate"] == pytest.approx(estimate, rel=1e-6, abs=1e-9), name
            assert ours[key]["se"] == pytest.approx(gee.bse[name], rel=1e-6), name

    scores = pd.read_csv(tmp_path / "scores.csv")
    for measure in ("credibility", "likeability", "trust"):
        lmm = smf.mixedlm(
            f"{measure} ~ C(condition, Treatment('still')) + C(position)",
            scores,
            groups=scores["participant"],
        ).fit(reml=True)
        coefficients = models["scores"][measure]["coefficients"]
        fitted = {(c["term"], c["level"]): c["estimate"] for c in coefficients}
        copy = lmm.fe_params["C(condition, Treatment('still'))[T.copy]"]
        assert fitted[("condition", "copy")] == pytest.approx(copy, rel=1e-4, abs=1e-6)
        assert fitted[("position", "3")] == pytest.approx(
            lmm.fe_params["C(position)[T.3]"], rel=1e-4, abs=1e-6
        )

    for measure in ("accepted", "credibility", "likeability", "trust"):
        effects = api["measures"][measure]["effect_sizes"]
        assert effects["n"] == 12
        assert effects["seed"] == 0


def test_analysis_page_loads_effect_sizes_and_models_after_its_first_render(
    client: TestClient, engine: Engine
) -> None:
    with session_scope(build_sessionmaker(engine)) as db:
        data = populate(db, 6)
    add_user(engine, "pia", "correct horse", "pi")
    login(client, "pia", "correct horse")
    page = client.get("/pi/analysis")
    source = f'data-src="/pi/analysis/extended?study={data.study_id}&amp;view=as_planned"'
    assert source in page.text
    assert 'id="effect-sizes"' not in page.text  # not in the first render
    fragment = client.get(f"/pi/analysis/extended?study={data.study_id}&view=as_planned")
    assert fragment.status_code == 200
    assert 'id="effect-sizes"' in fragment.text
    assert 'id="model-acceptance"' in fragment.text
    assert 'id="model-acceptance_by_kind"' in fragment.text
    assert "adjusted for suggestion kind (secondary: the kind is a mediator)" in fragment.text
    for measure in ("credibility", "likeability", "trust"):
        assert f'id="model-{measure}"' in fragment.text
    assert r"\label{tab:effects}" in fragment.text
    assert r"\label{tab:models}" in fragment.text
    latex = client.get("/pi/analysis/table1.tex").text
    assert r"\label{tab:stats}" in latex
    assert r"\label{tab:models}" in latex
    assert client.get("/pi/analysis/extended?study=999").status_code == 404
