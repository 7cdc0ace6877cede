"""A database error names the statement but never its bound values: those may be a
participant's free text, and error messages reach the log."""

from __future__ import annotations

import pytest
from sqlalchemy import Engine, text
from sqlalchemy.exc import DBAPIError


def test_a_database_error_does_not_carry_the_values(engine: Engine) -> None:
    secret = "my private answer 7f3a"
    with pytest.raises(DBAPIError) as caught, engine.connect() as connection:
        connection.execute(text("INSERT INTO no_such_table (x) VALUES (:x)"), {"x": secret})
    message = str(caught.value)
    assert "no_such_table" in message
    assert secret not in message
