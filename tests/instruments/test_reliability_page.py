"""The analysis page shows the coders' agreement per ELAN tier once two coders' files of a
session have been imported, and nothing about it before."""

from __future__ import annotations

from typing import Any

from fastapi.testclient import TestClient
from sqlalchemy import Engine

from chameleons.backend.db import build_sessionmaker, session_scope
from chameleons.backend.models import CodedAnnotation
from tests.backend.test_auth import add_user, login
from tests.support.factories import populate

SMILES = {"A": [(1000, 3000, "smile"), (5000, 6000, "frown")],
          "B": [(1000, 3000, "smile"), (5000, 6000, "smile")]}  # fmt: skip


def test_the_analysis_page_shows_the_coders_agreement(
    client: TestClient, engine: Engine, settings: Any
) -> None:
    with session_scope(build_sessionmaker(engine)) as db:
        data = populate(db, 6)
    add_user(engine, "pia", "correct horse", "pi")
    login(client, "pia", "correct horse")
    before = client.get("/pi/analysis")
    assert before.status_code == 200
    assert 'id="coder-agreement"' not in before.text
    with session_scope(build_sessionmaker(engine)) as db:
        for coder, spans in SMILES.items():
            for start, end, value in spans:
                db.add(CodedAnnotation(session_id=data.session_ids[0], coder=coder,
                                       tier="smiles", start_ms=start, end_ms=end, value=value,
                                       source_file=f"{coder}.eaf"))  # fmt: skip
    page = client.get(f"/pi/analysis?study={data.study_id}")
    assert page.status_code == 200
    section = page.text.split('id="coder-agreement"', 1)[1].split("</section>", 1)[0]
    assert "agreement (ELAN)" in section
    assert '<tr data-tier="smiles"><td>smiles</td><td>A, B</td><td>1</td><td>50</td>' in section
    assert "A vs B: 0.667" in section
