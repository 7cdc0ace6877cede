from __future__ import annotations

from pathlib import Path

from alembic import command
from alembic.autogenerate import compare_metadata
from alembic.migration import MigrationContext
from sqlalchemy import Engine, inspect

from chameleons.backend.db import build_engine
from chameleons.backend.migrate import alembic_config, current_revision, head_revision, upgrade
from chameleons.backend.models import Base


def test_migrations_reach_head(engine: Engine) -> None:
    assert current_revision(engine) == head_revision()


def test_models_and_migrations_do_not_drift(engine: Engine) -> None:
    with engine.connect() as connection:
        context = MigrationContext.configure(connection, opts={"compare_type": True})
        diff = compare_metadata(context, Base.metadata)
    assert diff == [], f"models and migrations differ; write a migration: {diff}"


def test_every_model_table_exists_with_named_constraints(engine: Engine) -> None:
    inspector = inspect(engine)
    tables = set(inspector.get_table_names())
    assert set(Base.metadata.tables) <= tables
    uniques = {u["name"] for u in inspector.get_unique_constraints("participant")}
    assert "uq_participant_study_id_code" in uniques


ROWS_AT_0001 = [
    "INSERT INTO study VALUES (1, 's', '{}', 'h', 0, 1, '2026-01-01')",
    "INSERT INTO plan_row VALUES (1, 1, 1, '[]', 0, '2026-01-01')",
    "INSERT INTO participant VALUES (1, 1, 'P001', 1, 'active', 0, NULL, '2026-01-01')",
    "INSERT INTO session VALUES (1, 1, 1, 1, 'b', 'running', 1, 't', 'c', 0, '2026-01-01', "
    "NULL, NULL)",
    "INSERT INTO interaction VALUES (1, 1, 1, 'done', 'copy', 'copy', 'f1', 'Nova', 'face-1', "
    "'lunar', 'better', '[]', NULL, NULL, NULL, NULL, NULL)",
    "INSERT INTO suggestion VALUES (1, 1, 1, 'x', 3, 1, 'optimal', 1, '2026-01-01', NULL)",
    "INSERT INTO questionnaire_response VALUES (1, 1, 1, 1, 'trust', 'v1', 'honest', 5, NULL, "
    "'2026-01-01')",
    "INSERT INTO recording VALUES (1, 1, 'agent', 'a.parquet', 10, 100, '2026-01-01')",
    "INSERT INTO event VALUES (1, 1, 1, 1, 'session.started', 'wizard', '2026-01-01', NULL, "
    "NULL, '{}')",
]


def test_upgrading_sqlite_keeps_every_row(tmp_path: Path) -> None:
    """Rebuilding a table (SQLite batch migrations) drops the old one; with foreign keys on,
    SQLite would delete the rows that refer to it (ON DELETE CASCADE). Data written at the
    first revision must all be there at head. (PostgreSQL alters tables in place.)"""
    url = f"sqlite:///{tmp_path / 'old.sqlite3'}"
    command.upgrade(alembic_config(url), "0001")
    engine = build_engine(url)
    with engine.begin() as connection:
        for statement in ROWS_AT_0001:
            connection.exec_driver_sql(statement)
    at_0001 = set(inspect(engine).get_table_names())  # later tables cannot have old rows
    tables = [
        table.name
        for table in Base.metadata.sorted_tables
        if table.name != "staff_user" and table.name in at_0001
    ]
    with engine.connect() as connection:
        before = {
            t: connection.exec_driver_sql(f'SELECT COUNT(*) FROM "{t}"').scalar() for t in tables
        }
    assert all(count == 1 for count in before.values()), before
    upgrade(url)
    with engine.connect() as connection:
        after = {
            t: connection.exec_driver_sql(f'SELECT COUNT(*) FROM "{t}"').scalar() for t in tables
        }
        assert connection.exec_driver_sql("PRAGMA foreign_keys").scalar() == 1
    assert after == before
    engine.dispose()
