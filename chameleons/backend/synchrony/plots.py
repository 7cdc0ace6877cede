"""The cross-correlation by lag of one interaction with its surrogate band, as an SVG for
the PI's session page (matplotlib's object API with the Agg canvas, as the analysis page's
plots: no pyplot state shared between requests)."""

from __future__ import annotations

import io
from typing import Any

from chameleons.backend.analysis.plots import BOX_COLOUR, LINE_COLOUR

BAND_COLOUR = "#8a94a6"
PEAK_COLOUR = "#b42318"


def _values(points: list[Any]) -> list[float]:
    return [float("nan") if v is None else float(v) for v in points]


def plot_synchrony(curves: dict[str, Any], title: str, *, delay: float | None = None) -> bytes:
    """``curves``: the stored lag curves (``lags_s``, ``curve``, ``head``, ``face``,
    ``surrogate_mean``, ``surrogate_high``); positive lags: the robot later."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    figure = Figure(figsize=(6.4, 2.9), dpi=100, layout="constrained")
    FigureCanvasAgg(figure)
    axes = figure.add_subplot()
    lags = _values(curves.get("lags_s", []))
    high, mean = curves.get("surrogate_high") or [], curves.get("surrogate_mean") or []
    if high and mean:
        axes.fill_between(lags, _values(mean), _values(high), color=BAND_COLOUR, alpha=0.3,
                          linewidth=0, label="surrogates: mean to 95%")  # fmt: skip
    for key, colour, width, label in (("head", LINE_COLOUR, 0.9, "head"),
                                      ("face", "#6f9a4d", 0.9, "face"),
                                      ("curve", BOX_COLOUR, 1.8, "all channels")):  # fmt: skip
        if curves.get(key):
            axes.plot(lags, _values(curves[key]), color=colour, linewidth=width, label=label)
    if delay is not None:
        axes.axvline(delay, color=PEAK_COLOUR, linestyle="--", linewidth=1,
                     label=f"configured delay {delay:g} s")  # fmt: skip
    axes.axvline(0, color="#444", linewidth=0.6)
    axes.set_xlabel("lag (s): < 0 participant follows robot · robot follows participant > 0")
    axes.set_ylabel("mean |Fisher z|")
    axes.set_title(title, fontsize=10)
    axes.grid(alpha=0.3)
    axes.legend(fontsize=7, frameon=False, loc="upper left")
    buffer = io.BytesIO()
    figure.savefig(buffer, format="svg", metadata={"Date": None})
    return buffer.getvalue()
