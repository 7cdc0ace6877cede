"""The export tables as pandas DataFrames, typed by the codebook: the one place a table
becomes a frame.

The row generators (:mod:`rows`, :mod:`scoring`) read the database in batches; here each
batch becomes a frame whose dtypes follow the table's columns (``string``, nullable
``Int64``, ``float64``, nullable ``boolean``, UTC ``datetime64[ms]``), so every writer that
works on frames (Parquet, SPSS, Stata) and the analysis see the same typed values.
:func:`table_frame` gives the whole table; :func:`table_frames` the batches, for writers
that stream.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator, Mapping, Sequence
from itertools import islice
from typing import TYPE_CHECKING, Any

from chameleons.backend.export.columns import Column, TableSpec

if TYPE_CHECKING:  # pandas is imported where it is used: the CLI starts faster
    import pandas as pd

BATCH_ROWS = 1000
DTYPES = {
    "string": "string",
    "integer": "Int64",
    "number": "float64",
    "boolean": "boolean",
}


def _series(column: Column, values: list[Any]) -> pd.Series:
    import pandas as pd

    if column.type == "datetime":
        return pd.to_datetime(pd.Series(values, dtype="object"), utc=True, format="ISO8601").astype(
            "datetime64[ms, UTC]"
        )
    if column.type == "number":
        return pd.Series([None if v is None else float(v) for v in values], dtype="float64")
    return pd.Series(values, dtype=DTYPES[column.type])


def frame(table: TableSpec, rows: Sequence[Mapping[str, Any]]) -> pd.DataFrame:
    """A typed frame of ``rows`` with exactly the table's columns, in order."""
    import pandas as pd

    data = {c.name: _series(c, [row.get(c.name) for row in rows]) for c in table.columns}
    return pd.DataFrame(data, columns=table.column_names)


def table_frames(table: TableSpec, rows: Iterable[Mapping[str, Any]]) -> Iterator[pd.DataFrame]:
    """The table in typed frames of at most ``BATCH_ROWS`` rows (at least one, maybe empty)."""
    iterator = iter(rows)
    first = True
    while (batch := list(islice(iterator, BATCH_ROWS))) or first:
        first = False
        yield frame(table, batch)


def table_frame(table: TableSpec, rows: Iterable[Mapping[str, Any]]) -> pd.DataFrame:
    import pandas as pd

    return pd.concat(list(table_frames(table, rows)), ignore_index=True)


def records(data: pd.DataFrame) -> list[dict[str, Any]]:
    """Rows as plain dicts with ``None`` for missing cells (pandas' NA and NaN are not
    values the analysis should see)."""
    plain = data.astype(object).where(data.notna(), None)
    return [dict(row) for row in plain.to_dict("records")]
