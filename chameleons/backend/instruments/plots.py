"""An imported instrument stream under the session's timeline, as an SVG for the PI's
session page (matplotlib's object API with the Agg canvas, as the synchrony plot)."""

from __future__ import annotations

import io
import itertools
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq

from chameleons.backend.models import InstrumentStream

# The analysis page's plot colours (backend/analysis/plots.py), repeated rather than
# imported: the analysis page shows the coders' agreement from this feature.
LINE_COLOUR = "#5b6575"
BOX_COLOUR = "#1f6feb"
MAX_POINTS = 4000  # per channel: a min/max envelope keeps the peaks of a longer stream
MAX_CHANNELS = 8
EVENT_COLOUR = "#8a94a6"
COLOURS = (LINE_COLOUR, BOX_COLOUR, "#6f9a4d", "#b42318", "#7a4fb0", "#c7831a", "#2b8a8a",
           "#555555")  # fmt: skip


def envelope(times: np.ndarray, values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """At most ``MAX_POINTS`` points: each bucket's minimum and maximum, in time order."""
    if len(times) <= MAX_POINTS:
        return times, values
    buckets = MAX_POINTS // 2
    edges = np.linspace(0, len(times), buckets + 1).astype(int)
    out_t, out_v = [], []
    for start, end in itertools.pairwise(edges):
        if end <= start:
            continue
        chunk = values[start:end]
        if np.all(np.isnan(chunk)):
            continue
        low, high = int(np.nanargmin(chunk)), int(np.nanargmax(chunk))
        for k in sorted({low, high}):
            out_t.append(times[start + k])
            out_v.append(chunk[k])
    return np.asarray(out_t), np.asarray(out_v)


def plot_stream(stream: InstrumentStream, data_dir: Path, event_times: list[float],
                span: tuple[float, float] | None = None) -> bytes:  # fmt: skip
    """The stream's channels (the first eight) or its markers over the session's time in
    minutes, with the session's timeline events as faint ticks."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    table = pq.read_table(data_dir / stream.path)
    times = table.column("time").to_numpy().astype(np.float64) / 60.0
    figure = Figure(figsize=(6.4, 2.2), dpi=100, layout="constrained")
    FigureCanvasAgg(figure)
    axes = figure.add_subplot()
    for moment in event_times:
        axes.axvline(moment / 60.0, color=EVENT_COLOUR, linewidth=0.5, alpha=0.5)
    if "value" in table.column_names:
        values = table.column("value").to_pylist()
        axes.vlines(times, 0, 1, color=BOX_COLOUR, linewidth=1.2)
        for t, text in list(zip(times, values, strict=True))[:30]:
            axes.text(t, 1.02, str(text)[:24], rotation=45, fontsize=6, ha="left", va="bottom")
        axes.set_yticks([])
        axes.set_ylim(0, 1.6)
    else:
        for i, label in enumerate(stream.channels[:MAX_CHANNELS]):
            values = table.column(label).to_numpy().astype(np.float64)
            t, v = envelope(times, values)
            axes.plot(t, v, color=COLOURS[i % len(COLOURS)], linewidth=0.8, label=label)
        if stream.channels:
            axes.legend(fontsize=6, frameon=False, loc="upper right",
                        ncols=min(4, len(stream.channels[:MAX_CHANNELS])))  # fmt: skip
    if span is not None:
        axes.set_xlim(span[0] / 60.0, span[1] / 60.0)
    axes.set_xlabel("minutes from the session's start (server clock)")
    axes.set_title(f"{stream.name} ({stream.stream_type or 'no type'})", fontsize=9)
    axes.grid(alpha=0.3)
    buffer = io.BytesIO()
    figure.savefig(buffer, format="svg", metadata={"Date": None})
    return buffer.getvalue()
