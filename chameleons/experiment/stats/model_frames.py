"""The regression models' data (:mod:`.models`): score and suggestion rows as pandas frames
with checked numbers and decisions, and categorical factors with a chosen reference level."""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from typing import TYPE_CHECKING, Any

from chameleons.experiment.stats.model_results import ModelInputError

if TYPE_CHECKING:  # pandas is imported where it is used: the CLI starts faster
    import pandas as pd


def score_frame(rows: Iterable[Mapping[str, Any]], measures: Sequence[str]) -> pd.DataFrame:
    import pandas as pd

    frame = pd.DataFrame(list(rows))
    _require(frame, ["participant", "condition"], "scores")
    frame["participant"] = frame["participant"].astype(str)
    frame["condition"] = frame["condition"].astype(str)
    if "position" in frame:  # older score files have none: the models then leave it out
        frame["position"] = _numbers(frame["position"], "position").astype("Int64")
    for measure in measures:
        if measure in frame:
            frame[measure] = _numbers(frame[measure], measure)
    return frame


def suggestion_frame(rows: Iterable[Mapping[str, Any]]) -> pd.DataFrame:
    """Per-suggestion rows: participant, condition, position, item_set, kind, accepted
    (true/false, empty when never decided)."""
    import pandas as pd

    frame = pd.DataFrame(list(rows))
    _require(frame, ["participant", "condition", "position", "item_set", "kind", "accepted"],
             "suggestions")  # fmt: skip
    frame["participant"] = frame["participant"].astype(str)
    frame["position"] = _numbers(frame["position"], "position").astype("Int64")
    frame["accepted"] = frame["accepted"].map(_decision)
    return frame


def _require(frame: pd.DataFrame, columns: list[str], table: str) -> None:
    import pandas as pd

    missing = [c for c in columns if c not in frame.columns]
    if missing and len(frame):
        raise ModelInputError(f"{table}: missing column(s) {', '.join(missing)}")
    for column in missing:
        frame[column] = pd.Series(dtype=object)


def _numbers(column: pd.Series, name: str) -> pd.Series:
    import pandas as pd

    text = column.map(lambda v: None if v is None or str(v).strip() == "" else v)
    converted = pd.to_numeric(text, errors="coerce")
    bad = converted.isna() & text.notna()
    if bad.any():
        raise ModelInputError(f"{name}: {text[bad].iloc[0]!r} is not a number")
    return converted.astype("float64")


def _decision(value: object) -> float | None:
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return None
    if isinstance(value, bool):
        return float(value)
    text = str(value).strip().lower()
    if text in {"true", "1", "yes", "1.0"}:
        return 1.0
    if text in {"false", "0", "no", "0.0"}:
        return 0.0
    if text in {"", "na", "nan", "none", "null"}:
        return None
    raise ModelInputError(f"accepted: {value!r} is not true/false")


def categorical(series: pd.Series, first: str | None = None) -> pd.Series:
    """A categorical whose first category (the model's reference) is ``first``."""
    import pandas as pd

    levels = sorted({str(v) for v in series}, key=_level_key)
    if first is not None and first in levels:
        levels.remove(first)
        levels.insert(0, first)
    return pd.Series(pd.Categorical(series.astype(str), categories=levels), index=series.index)


def _level_key(level: str) -> tuple[int, float | str]:
    try:
        return (0, float(level))
    except ValueError:
        return (1, level)
