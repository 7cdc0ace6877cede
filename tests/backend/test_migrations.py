from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest
from alembic import command
from alembic.autogenerate import compare_metadata
from alembic.migration import MigrationContext
from sqlalchemy import Engine, inspect, text
from sqlalchemy.engine import make_url

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


def _next_session_id_after_top_deleted(engine: Engine) -> tuple[int, int]:
    """Delete the newest session (as a withdrawal does), add one: (deleted id, new id)."""
    with engine.begin() as connection:
        top = int(connection.exec_driver_sql("SELECT MAX(id) FROM session").scalar_one())
        connection.exec_driver_sql(f"DELETE FROM event WHERE session_id = {top}")
        connection.exec_driver_sql(f"DELETE FROM session WHERE id = {top}")
        connection.exec_driver_sql(
            "INSERT INTO session (study_id, participant_id, plan_row_id, booth, state, "
            "current_position, phone_token, short_code, is_rehearsal, created_at) "
            "VALUES (1, 1, 1, 'b', 'pending', 1, 'new-token', 'new-code', false, "
            "'2026-01-02')"
        )
        new = int(connection.exec_driver_sql("SELECT MAX(id) FROM session").scalar_one())
    return top, new


SESSION_2 = (
    "INSERT INTO session (id, study_id, participant_id, plan_row_id, booth, state, "
    "current_position, phone_token, short_code, is_rehearsal, created_at) "
    "VALUES (2, 1, 1, 1, 'b', 'pending', 1, 't2', 'c2', false, '2026-01-01')"
)


def test_upgraded_sqlite_never_reuses_ids(tmp_path: Path) -> None:
    url = f"sqlite:///{tmp_path / 'old.sqlite3'}"
    command.upgrade(alembic_config(url), "0001")
    engine = build_engine(url)
    with engine.begin() as connection:
        for statement in ROWS_AT_0001:
            connection.exec_driver_sql(statement)
    engine.dispose()
    upgrade(url, "0004_i13_consent")  # the revision id of 0007_consent.py
    with engine.begin() as connection:
        connection.exec_driver_sql(SESSION_2)
    upgrade(url)
    with engine.connect() as connection:
        schema = connection.exec_driver_sql(
            "SELECT sql FROM sqlite_master WHERE name = 'session'"
        ).scalar()
        assert "AUTOINCREMENT" in str(schema)
        kept = connection.exec_driver_sql("SELECT COUNT(*) FROM interaction").scalar()
    assert kept == 1
    deleted, new = _next_session_id_after_top_deleted(engine)
    assert (deleted, new) == (2, 3)
    engine.dispose()


@pytest.fixture
def postgres_server(postgres_url: str) -> Iterator[str]:
    """An empty database of this test's own next to the workers' (never migrated here)."""
    url = make_url(postgres_url)
    name = f"{url.database}_upgrade"
    admin = build_engine(postgres_url)
    with admin.connect().execution_options(isolation_level="AUTOCOMMIT") as conn:
        conn.execute(text(f'DROP DATABASE IF EXISTS "{name}" WITH (FORCE)'))
        conn.execute(text(f'CREATE DATABASE "{name}"'))
    yield url.set(database=name).render_as_string(hide_password=False)
    with admin.connect().execution_options(isolation_level="AUTOCOMMIT") as conn:
        conn.execute(text(f'DROP DATABASE IF EXISTS "{name}" WITH (FORCE)'))
    admin.dispose()


ROWS_AT_0002 = [
    "INSERT INTO study (name, config, config_hash, plan_seed, is_active, created_at) "
    "VALUES ('s', '{}', 'h', 0, true, '2026-01-01')",
    "INSERT INTO plan_row (study_id, row_number, interactions, withdrawals, created_at) "
    "VALUES (1, 1, '[]', 0, '2026-01-01')",
    "INSERT INTO participant (study_id, code, plan_row_id, status, is_rehearsal, created_at) "
    "VALUES (1, 'P001', 1, 'active', false, '2026-01-01')",
    "INSERT INTO session (study_id, participant_id, plan_row_id, booth, state, "
    "current_position, phone_token, short_code, is_rehearsal, created_at) "
    "VALUES (1, 1, 1, 'b', 'pending', 1, 't1', 'c1', false, '2026-01-01')",
    "INSERT INTO session (study_id, participant_id, plan_row_id, booth, state, "
    "current_position, phone_token, short_code, is_rehearsal, created_at) "
    "VALUES (1, 1, 1, 'b', 'pending', 1, 't2', 'c2', false, '2026-01-01')",
    "DELETE FROM session WHERE id = 2",  # withdrawn before the upgrade
]


def test_upgraded_postgres_continues_after_the_old_sequence(postgres_server: str) -> None:
    """SERIAL becomes an identity column that starts where the sequence was, not at
    MAX(id)+1 (which would reuse an id deleted from the top before the upgrade)."""
    upgrade(postgres_server, "0004_i13_consent")  # the revision id of 0007_consent.py
    engine = build_engine(postgres_server)
    with engine.begin() as connection:
        for statement in ROWS_AT_0002:
            connection.exec_driver_sql(statement)
    upgrade(postgres_server)
    with engine.connect() as connection:
        identity = connection.exec_driver_sql(
            "SELECT attidentity FROM pg_attribute WHERE attrelid = 'session'::regclass "
            "AND attname = 'id'"
        ).scalar()
        assert identity == "d"
    deleted, new = _next_session_id_after_top_deleted(engine)
    assert deleted == 1
    assert new == 3, "an id used before the upgrade was handed out again"
    engine.dispose()


def test_migration_files_are_named_in_the_order_they_apply() -> None:
    """A maintainer reads ``versions/`` top to bottom as the order the schema grew: each
    file's number is its place in the chain from the first revision to head, and no file
    name carries the number of an internal work item (``_i13_``). The revision ids inside
    stay as they were, so databases created before the renaming still upgrade."""
    from alembic.script import ScriptDirectory

    scripts = ScriptDirectory.from_config(alembic_config("sqlite://"))
    chain = list(reversed(list(scripts.walk_revisions("base", "heads"))))
    names = [Path(str(script.path)).name for script in chain]
    assert len(scripts.get_heads()) == 1, "one head: chain a new migration after the last"
    assert [int(name[:4]) for name in names] == list(range(1, len(names) + 1)), names
    assert not [name for name in names if any(part[:1] == "i" and part[1:].isdigit()
                                              for part in name[:-3].split("_"))], names
