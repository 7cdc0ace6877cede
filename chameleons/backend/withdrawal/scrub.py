"""After a withdrawal commits: what the database's files, and copies elsewhere, still hold.

SQLite keeps deleted rows' bytes in free pages of the file unless ``secure_delete`` is on
(set on every connection, :mod:`chameleons.backend.db`: deleted content is overwritten with
zeros), and in WAL mode the write-ahead log (``<db>-wal``) still holds page images written
before; a ``wal_checkpoint(TRUNCATE)`` copies the committed pages into the database file and
empties the log. It cannot while another connection is reading, and the report says so.

PostgreSQL marks deleted rows dead; their bytes stay in the table files until VACUUM frees
the space and later rows overwrite it (``VACUUM FULL`` rewrites the tables at once, with an
exclusive lock), and WAL archives and base backups keep them for their own retention. The
server does not run these for you; the report and docs/science.md say so.
"""

from __future__ import annotations

from sqlalchemy import Engine

OUTSIDE_THE_SERVER = (
    "Exports, plots and analysis files downloaded before now, and folders written by "
    "`chameleons export`, are not on the server: delete them where they were saved.",
    "Backups and copies of the database made before now still hold the rows: delete or "
    "re-make them.",
)
POSTGRES_KEEPS = (
    "PostgreSQL keeps the deleted rows' bytes in its table files until VACUUM frees the "
    "space and new rows overwrite it (autovacuum does this on its own schedule; VACUUM FULL "
    "on the study's tables rewrites them now), and in write-ahead-log archives for their "
    "retention."
)


def scrub_database(engine: Engine) -> tuple[list[str], list[str]]:
    """Run after the commit: (removed, kept) sentences about the database's own files."""
    if engine.dialect.name != "sqlite":
        return [], [POSTGRES_KEEPS, *OUTSIDE_THE_SERVER]
    with engine.connect() as connection:
        secure = connection.exec_driver_sql("PRAGMA secure_delete").scalar()
        busy = connection.exec_driver_sql("PRAGMA wal_checkpoint(TRUNCATE)").first()
        connection.commit()
    removed, kept = [], list(OUTSIDE_THE_SERVER)
    if secure:
        removed.append("the deleted rows' bytes in the database file (overwritten with zeros)")
    else:
        kept.insert(
            0,
            "The database file may still hold the deleted rows' bytes: this "
            "connection did not have secure_delete on. Run VACUUM to rewrite it.",
        )
    if busy is not None and busy[0] == 0:
        removed.append("the database's write-ahead log (emptied)")
    else:
        kept.insert(
            0,
            "The database's write-ahead log could not be emptied now (another "
            "connection was reading); it still holds the rows until the next checkpoint.",
        )
    return removed, kept
