"""Plots a reader of the paper expects: per measure, the conditions side by side (box per
condition) with each participant's values connected across conditions.

matplotlib is used through its object API with the Agg canvas chosen here, in code, per
figure: no pyplot global state, so concurrent requests cannot draw into each other's
figures and importing this module changes no backend.
"""

from __future__ import annotations

import io
from collections.abc import Mapping, Sequence
from typing import Any, Literal

PlotFormat = Literal["svg", "png", "pdf"]
MEDIA_TYPES: dict[PlotFormat, str] = {
    "svg": "image/svg+xml",
    "png": "image/png",
    "pdf": "application/pdf",
}
MEASURE_TITLES = {
    "accepted": "Accepted robot suggestions",
    "credibility": "Credibility",
    "likeability": "Likeability",
    "trust": "Trust",
}
LINE_COLOUR = "#5b6575"
BOX_COLOUR = "#1f6feb"


def _jitter(index: int, spread: float) -> float:
    """A fixed small offset per participant, so tied lines stay visible (deterministic)."""
    return ((index * 7919) % 11 - 5) / 5 * spread


def plot_measure(
    participants: Sequence[Sequence[float]],
    measure: str,
    conditions: Sequence[str],
    labels: Mapping[str, str],
    value_range: tuple[float, float],
    subtitle: str = "",
    fmt: PlotFormat = "svg",
) -> bytes:
    """``participants``: the analysed values, one list per participant in condition order
    (the analysis' own complete cases, so the plot shows exactly what was tested)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    figure = Figure(figsize=(4.6, 3.8), dpi=110, layout="constrained")
    FigureCanvasAgg(figure)
    axes = figure.add_subplot()
    positions = list(range(1, len(conditions) + 1))
    low, high = value_range
    discrete = measure == "accepted"
    for index, values in enumerate(participants):
        dx = _jitter(index, 0.06)
        dy = _jitter(index + 3, 0.06) if discrete else 0.0
        axes.plot(
            [p + dx for p in positions],
            [v + dy for v in values],
            color=LINE_COLOUR,
            alpha=0.45,
            linewidth=1,
            marker="o",
            markersize=3,
        )
    if participants:
        columns = [[values[j] for values in participants] for j in range(len(conditions))]
        axes.boxplot(
            columns,
            positions=positions,
            widths=0.42,
            showfliers=False,
            patch_artist=True,
            boxprops={"facecolor": BOX_COLOUR, "alpha": 0.18, "edgecolor": BOX_COLOUR},
            medianprops={"color": BOX_COLOUR, "linewidth": 2},
            whiskerprops={"color": BOX_COLOUR},
            capprops={"color": BOX_COLOUR},
        )
        means = [sum(column) / len(column) for column in columns]
        axes.scatter(positions, means, marker="D", color="#b42318", zorder=3, label="mean")
        axes.legend(loc="lower right", fontsize=8, frameon=False)
    else:
        axes.text(0.5, 0.5, "no complete participants", transform=axes.transAxes, ha="center")
    axes.set_xticks(positions, [labels.get(c, c) for c in conditions])
    margin = (high - low) * 0.06
    axes.set_ylim(low - margin, high + margin)
    axes.set_ylabel(f"{MEASURE_TITLES.get(measure, measure)} ({low:g}-{high:g})")
    title = f"{MEASURE_TITLES.get(measure, measure)} (n = {len(participants)})"
    axes.set_title(title + (f"\n{subtitle}" if subtitle else ""), fontsize=10)
    axes.grid(axis="y", alpha=0.3)
    buffer = io.BytesIO()
    figure.savefig(buffer, format=fmt, metadata=_metadata(fmt))
    return buffer.getvalue()


def _metadata(fmt: PlotFormat) -> dict[str, Any]:
    """Reproducible files: no creation date in SVG/PDF."""
    if fmt == "svg":
        return {"Date": None}
    if fmt == "pdf":
        return {"CreationDate": None}
    return {}
