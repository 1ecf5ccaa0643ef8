"""The reproduction envelope's figures for a reviewer: a forest plot of every published number
against the spread of the members' reproductions, and a tornado of what drives each table.

Both read the envelope's tables as they are written (the scorecard, one row per published number;
the Morris sensitivity, long format) and draw nothing the tables do not hold. Text from the tables
is data: it is escaped so a ``$`` in a quantity is printed, never parsed as mathtext. Pure apart
from :func:`forest_figure` and :func:`tornado_figure`, which save through
:func:`selfsense.io.provenance.save_figure` (PNG and PDF atomically, plus the provenance sidecar).
"""

from __future__ import annotations

import math
import os
import re
from collections.abc import Iterable, Mapping
from typing import Any

import numpy as np
import pandas as pd
from matplotlib.lines import Line2D
from matplotlib.patches import Patch

from selfsense.chapters import figures  # before pyplot: it chooses the Agg backend
from selfsense.envelope.verdicts import EDGE, edge_rows
from selfsense.io.provenance import save_figure

plt = figures.plt

#: the forest plot's deviation axis [% of |published|]: a reproduction off by a factor of three, or
#: of the wrong sign, is as wrong as the reviewer needs to see; beyond, a row is drawn at the edge
AXIS = (-100.0, 200.0)
#: the envelope's verdicts, in the order the counts are given, and the colour of their bar (None:
#: no bar, there is no envelope to draw)
VERDICT_COLOURS: dict[str, str | None] = {
    "consistent": "#2ca02c",
    "consistent (uninformative)": "#b7d7a8",
    "inconsistent": "#d62728",
    "no verdict": "#c7c7c7",  # the registry gives none: the envelope shown for information
    "no envelope": None,
}
#: a verdict the module does not know is still drawn, in neutral grey
UNKNOWN_COLOUR = "0.6"
#: how a bar whose verdict is on the edge is hatched, and the hatch's ink
EDGE_HATCH, EDGE_INK = "////", "0.25"
#: the card's columns drawn in the forest plot, each as a deviation from the published value
VALUES = ("p2.5", "p50", "p97.5", "reproduced")
#: a row label's length: long quantity names would squeeze the panels to nothing
LABEL_CHARS = 60
#: height of one forest row and the tallest figure [inch]: a 60-inch PNG at 150 dpi is 9000 px,
#: still opened by any viewer; past it rows overlap rather than the file growing without bound
ROW_INCH, MAX_INCH = 0.16, 60.0
#: the tornado's grid width, and the length of a factor's label there
TORNADO_COLUMNS, FACTOR_CHARS = 3, 32
EMPTY_SENSITIVITY = "no Morris screening in this envelope (Latin hypercube members): no drivers"


# --- tables -------------------------------------------------------------------------------------


def deviation(values: Any, published: Any) -> np.ndarray:
    """``(values − published) / |published| · 100``: a reproduction's deviation in % of the
    published magnitude, so numbers of any unit and sign share one axis (NaN stays NaN)."""
    values = np.asarray(values, dtype=float)
    published = np.asarray(published, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        return (values - published) / np.abs(published) * 100.0


def beyond(values: Any, axis: tuple[float, float] = AXIS) -> np.ndarray:
    """−1 where a deviation lies left of the axis, +1 right of it, 0 on it or NaN."""
    values = np.asarray(values, dtype=float)
    side = np.zeros(values.shape, dtype=int)
    side[values < axis[0]] = -1
    side[values > axis[1]] = 1
    return side


def cut(text: Any, chars: int) -> str:
    """``text`` cut to ``chars`` characters, the last an ellipsis when anything was cut."""
    text = str(text)
    return text if len(text) <= chars else text[: chars - 1] + "…"


def label(source: Any, quantity: Any, chars: int = LABEL_CHARS) -> str:
    """A row's label, ``source · quantity``, :func:`cut` to ``chars`` characters."""
    return cut(f"{source} · {quantity}", chars)


def deviations(card: pd.DataFrame, axis: tuple[float, float] = AXIS) -> pd.DataFrame:
    """The forest plot's rows: every row of ``card`` whose published value is not 0 (a deviation
    relative to 0 has no meaning), on the card's index, with ``chapter`` (text), ``label``,
    ``envelope verdict``, ``on the edge`` (false where the card has no such column), and for
    each of p2.5, p50, p97.5 and reproduced its deviation ``<name> [%]`` (:func:`deviation`, not
    clipped) and ``<name> beyond`` (:func:`beyond`)."""
    kept = card[card["published"].astype(float) != 0]
    out = pd.DataFrame(
        {
            "chapter": kept["chapter"].astype(str),
            "label": [label(s, q) for s, q in zip(kept["source"], kept["quantity"])],
            "envelope verdict": kept["envelope verdict"].astype(str),
            EDGE: edge_rows(kept),
        },
        index=kept.index,
    )
    for name in VALUES:
        dev = deviation(kept[name], kept["published"])
        out[f"{name} [%]"] = dev
        out[f"{name} beyond"] = beyond(dev, axis)
    return out


def drivers(sensitivity: pd.DataFrame, card: pd.DataFrame, top: int = 8) -> pd.DataFrame:
    """Per table (``source``), its ``top`` factors by the mean of ``mu_star [%]`` over the table's
    rows (NaN ignored: a published 0 has no relative μ*; a factor with no finite μ* is dropped),
    largest first, ties by name. Columns ``source``, ``factor``, ``mu_star [%]``, ``rows`` (the
    finite values averaged), ``rank`` (1 = largest); tables in the card's order, then any others in
    the sensitivity's."""
    columns = ["source", "factor", "mu_star [%]", "rows", "rank"]
    if sensitivity.empty:
        return pd.DataFrame(columns=columns)
    finite = sensitivity.dropna(subset=["mu_star [%]"])
    means = (
        finite.groupby(["source", "factor"], sort=False)["mu_star [%]"]
        .agg(["mean", "count"])
        .reset_index()
        .rename(columns={"mean": "mu_star [%]", "count": "rows"})
    )
    order = _table_order(sensitivity, card)
    means["table"] = means["source"].map({s: i for i, s in enumerate(order)})
    means = means.sort_values(
        ["table", "mu_star [%]", "factor"], ascending=[True, False, True], kind="stable"
    )
    means["rank"] = means.groupby("source", sort=False).cumcount() + 1
    return means[means["rank"] <= top][columns].reset_index(drop=True)


def _table_order(sensitivity: pd.DataFrame, card: pd.DataFrame) -> list[str]:
    """The tables with sensitivity rows: in the card's order, then the others as they come."""
    present = list(dict.fromkeys(sensitivity["source"]))
    in_card = [s for s in dict.fromkeys(card["source"]) if s in set(present)]
    return in_card + [s for s in present if s not in set(in_card)]


def _chapters(chapters: Iterable[str]) -> list[str]:
    """Chapters in reading order: numbered ones by number, then named ones as they come."""
    unique = list(dict.fromkeys(chapters))
    numbered = sorted((c for c in unique if re.fullmatch(r"\d+", c)), key=int)
    return numbered + [c for c in unique if c not in numbered]


def plain(text: Any) -> str:
    """``text`` as matplotlib prints it literally: every ``$`` escaped, so a quantity such as
    ``$U_0$ amplitude`` is not typeset as mathtext (nor fails to parse as it)."""
    return str(text).replace("$", r"\$")


# --- figures ------------------------------------------------------------------------------------


def _numbers(n: int) -> str:
    return f"{n} number" if n == 1 else f"{n} numbers"


def _verdict_counts(verdicts: pd.Series) -> str:
    counts = verdicts.value_counts()
    known = [v for v in VERDICT_COLOURS if counts.get(v, 0)]
    other = [v for v in counts.index if v not in VERDICT_COLOURS]
    return ", ".join(f"{counts[v]} {v}" for v in known + other)


def _chapter_title(chapter: str, verdicts: pd.Series) -> str:
    name = f"Chapter {chapter}" if re.fullmatch(r"\d+", chapter) else chapter
    return plain(f"{name}: {_numbers(len(verdicts))} ({_verdict_counts(verdicts)})")


def _x_range(rows: pd.DataFrame, axis: tuple[float, float]) -> tuple[float, float]:
    """The drawn x range: the values' extent and 0, clipped to ``axis``, with a margin for the
    edge markers."""
    values = rows[[f"{v} [%]" for v in VALUES]].to_numpy(dtype=float).ravel()
    values = np.append(np.clip(values[np.isfinite(values)], *axis), 0.0)
    lo, hi = float(values.min()), float(values.max())
    if hi - lo < 1.0:  # a row at exactly 0 % still gets a readable axis
        lo, hi = lo - 1.0, hi + 1.0
    margin = 0.04 * (hi - lo)
    return lo - margin, hi + margin


def _edge(ax, y: float, side: int, axis, colour, size: float = 5.0) -> None:
    """A value beyond the axis: a triangle at the edge, pointing the way it went off."""
    ax.plot(
        axis[0] if side < 0 else axis[1],
        y,
        marker="<" if side < 0 else ">",
        ms=size,
        color=colour,
        mec="k",
        mew=0.4,
        ls="none",
        zorder=4,
    )


def _forest_panel(ax, rows: pd.DataFrame, axis: tuple[float, float]) -> None:
    for y, (_, row) in enumerate(rows.iterrows()):
        colour = VERDICT_COLOURS.get(row["envelope verdict"], UNKNOWN_COLOUR)
        lo, hi = row["p2.5 [%]"], row["p97.5 [%]"]
        if colour is not None and np.isfinite(lo) and np.isfinite(hi):
            left, right = np.clip([lo, hi], *axis)
            # hatched: a verdict one member's draw decides (selfsense.envelope.verdicts)
            hatch = EDGE_HATCH if row[EDGE] else None
            ink = EDGE_INK if hatch else colour
            ax.barh(
                y, right - left, left=left, height=0.56, color=colour, ec=ink, lw=0.6, hatch=hatch
            )
            for name in ("p2.5", "p97.5"):
                if row[f"{name} beyond"]:
                    _edge(ax, y, row[f"{name} beyond"], axis, colour)
        # the median and the nominal are drawn whatever the verdict: a number the members gave is
        # shown even when they were too few for an envelope
        median = row["p50 [%]"]
        if np.isfinite(median):
            if row["p50 beyond"]:
                _edge(ax, y, row["p50 beyond"], axis, colour or UNKNOWN_COLOUR, 4.0)
            else:
                ax.plot(median, y, marker="|", ms=7, mew=1.4, color="0.15", ls="none", zorder=3)
        nominal = row["reproduced [%]"]
        if np.isfinite(nominal):
            if row["reproduced beyond"]:
                _edge(ax, y, row["reproduced beyond"], axis, "k", 5.5)
            else:
                ax.plot(nominal, y, "o", ms=3.2, color="k", ls="none", zorder=5)
    ax.axvline(0.0, color="k", lw=0.8, zorder=2)
    for edge in axis:
        ax.axvline(edge, color="0.5", lw=0.5, ls=":", zorder=1)
    ax.set_yticks(range(len(rows)), [plain(t) for t in rows["label"]], fontsize=7)
    ax.set_ylim(len(rows) - 0.5, -0.5)  # the card's first row on top
    ax.grid(axis="x", alpha=0.3)


def _legend_handles() -> list:
    handles: list = [
        Patch(color=c, label=f"envelope p2.5–p97.5: {v}")
        for v, c in VERDICT_COLOURS.items()
        if c is not None
    ]
    return handles + [
        Patch(fc="white", ec=EDGE_INK, hatch=EDGE_HATCH, label="on the edge"),
        Line2D([], [], marker="|", ms=7, mew=1.4, color="0.15", ls="none", label="members' p50"),
        Line2D([], [], marker="o", ms=3.2, color="k", ls="none", label="nominal twin"),
        Line2D([], [], marker=">", ms=5, color="0.6", mec="k", ls="none", label="beyond the axis"),
    ]


def _chapter_panels(rows: pd.DataFrame, title: str, empty: str):
    """A figure of one panel per chapter of ``rows`` (its ``chapter`` column), stacked on a shared
    x axis, each as tall as its rows: (figure, [(axes, chapter, its rows)]), or a figure saying
    ``empty`` and no panel when there is no row."""
    chapters = _chapters(rows["chapter"])
    if not chapters:
        fig, ax = plt.subplots(figsize=(10.0, 2.0), constrained_layout=True)
        ax.axis("off")
        ax.text(0.5, 0.5, empty, ha="center")
        fig.suptitle(plain(title))
        return fig, []
    sizes = [int((rows["chapter"] == c).sum()) for c in chapters]
    height = min(MAX_INCH, ROW_INCH * len(rows) + 0.45 * len(chapters) + 1.6)
    fig, axes = plt.subplots(
        len(chapters),
        1,
        sharex=True,
        squeeze=False,
        figsize=(10.0, height),
        gridspec_kw={"height_ratios": [n + 1 for n in sizes]},  # +1: a 1-row panel stays visible
        constrained_layout=True,
    )
    return fig, [(ax, c, rows[rows["chapter"] == c]) for ax, c in zip(axes[:, 0], chapters)]


def forest(card: pd.DataFrame, title: str, axis: tuple[float, float] = AXIS):
    """The forest plot of :func:`forest_figure`, as a Figure."""
    rows = deviations(card, axis)
    zero = len(card) - len(rows)
    fig, panels = _chapter_panels(
        rows, title, "no published number other than 0: nothing to compare"
    )
    if not panels:
        return fig
    for ax, chapter, panel in panels:
        _forest_panel(ax, panel, axis)
        ax.set_title(_chapter_title(chapter, panel["envelope verdict"]), fontsize=8, loc="left")
    last = panels[-1][0]
    last.set_xlim(*_x_range(rows, axis))
    last.set_xlabel("deviation from the published value [% of |published|]")
    note = f"; {zero} with published 0 not drawn (no relative deviation)" if zero else ""
    fig.suptitle(plain(f"{title}\n{_numbers(len(rows))} published{note}"), fontsize=9)
    fig.legend(handles=_legend_handles(), loc="outside lower center", ncols=3, fontsize=7)
    return fig


def tornado(sensitivity: pd.DataFrame, card: pd.DataFrame, title: str, top: int = 8):
    """The tornado of :func:`tornado_figure`, as a Figure."""
    if sensitivity.empty:
        fig, ax = plt.subplots(figsize=(8.0, 2.0), constrained_layout=True)
        ax.axis("off")
        ax.text(0.5, 0.5, EMPTY_SENSITIVITY, ha="center", va="center", fontsize=9)
        fig.suptitle(plain(title))
        return fig
    ranked = drivers(sensitivity, card, top)
    tables = _table_order(sensitivity, card)
    chapters = card.drop_duplicates("source").set_index("source")["chapter"].astype(str)
    ncols = min(TORNADO_COLUMNS, len(tables))
    nrows = math.ceil(len(tables) / ncols)
    panel_inch = 0.9 + 0.22 * top
    fig, axes = plt.subplots(
        nrows,
        ncols,
        squeeze=False,
        figsize=(4.2 * ncols, min(MAX_INCH, panel_inch * nrows + 0.8)),
        constrained_layout=True,
    )
    for ax in axes.ravel()[len(tables) :]:
        ax.axis("off")
    for ax, table in zip(axes.ravel(), tables):
        numbers = sensitivity.loc[sensitivity["source"] == table, "quantity"].nunique()
        where = f"ch. {chapters[table]} · " if table in chapters.index else ""
        ax.set_title(plain(f"{table} ({where}{_numbers(numbers)})"), fontsize=8)
        factors = ranked[ranked["source"] == table]
        if factors.empty:
            ax.text(0.5, 0.5, "no relative μ* (published 0)", ha="center", transform=ax.transAxes)
            ax.set(xticks=[], yticks=[])
            continue
        names = [plain(cut(f, FACTOR_CHARS)) for f in factors["factor"]]
        ax.barh(range(len(factors)), factors["mu_star [%]"], color="#4c72b0", height=0.65)
        ax.set_yticks(range(len(factors)), names, fontsize=7)
        ax.set_ylim(max(top, len(factors)) - 0.5, -0.5)  # largest on top, one scale of slots
        ax.set_xlabel("mean μ* [% of |published|]", fontsize=7)
        ax.tick_params(axis="x", labelsize=7)
        ax.grid(axis="x", alpha=0.3)
    fig.suptitle(plain(title), fontsize=9)
    return fig


def _save(fig, path, inputs, config, pdf) -> None:
    try:
        save_figure(fig, path, inputs=inputs, config=config, pdf=pdf)
    finally:
        plt.close(fig)  # a long envelope run draws many: pyplot keeps every open figure


def forest_figure(
    card: pd.DataFrame,
    path: str | os.PathLike,
    title: str,
    *,
    inputs: Iterable[str | os.PathLike] = (),
    config: Mapping[str, Any] | None = None,
    pdf: bool = True,
) -> None:
    """A forest plot of the envelope scorecard at ``path`` (PNG, with ``pdf`` a PDF beside it,
    provenance).

    One row per published number other than 0, on a shared axis of deviation from the published
    value in % of |published| (:func:`deviations`), so a reviewer reads every number's agreement
    on one scale: the members' p2.5–p97.5 as a bar coloured by the envelope verdict (none without
    an envelope), their p50 as a tick, the nominal twin as a black dot, the published value as
    the line at 0. One panel per chapter, its height by its rows, titled with its verdict counts.
    The axis stops at :data:`AXIS`; a value beyond is a triangle at the edge, and a row with no
    value is still labelled, so no number drops out unseen. ``inputs``/``config`` go to the
    provenance sidecar.
    """
    _save(forest(card, title), path, inputs, config, pdf)


def tornado_figure(
    sensitivity: pd.DataFrame,
    card: pd.DataFrame,
    path: str | os.PathLike,
    title: str,
    top: int = 8,
    *,
    inputs: Iterable[str | os.PathLike] = (),
    config: Mapping[str, Any] | None = None,
    pdf: bool = True,
) -> None:
    """A tornado of what drives each table at ``path`` (PNG, with ``pdf`` a PDF beside it,
    provenance).

    One panel per table (``source``) with Morris rows, in the card's order, three to a row: its
    ``top`` factors by the mean over the table's numbers of μ* in % of |published|
    (:func:`drivers`), largest on top, so a reviewer sees which unknown to pin down first for a
    table. Without a Morris screening (a Latin hypercube envelope) a single panel says so.
    """
    _save(tornado(sensitivity, card, title, top), path, inputs, config, pdf)


# --- the validation's figures -------------------------------------------------------------------


def pit_histogram(histogram: Any, coverage: float, judged: int, title: str):
    """The pseudo-theses' PIT histogram: the held-out rows' F(z) in tenths of [0, 1], the flat
    line a calibrated predictive gives (a hump: too wide; a U: too narrow; a slope: biased)."""
    counts = np.asarray(histogram, dtype=float)
    fig, ax = plt.subplots(figsize=(5.0, 3.2))
    edges = np.linspace(0.0, 1.0, len(counts) + 1)
    ax.bar(edges[:-1], counts, width=np.diff(edges), align="edge", color="#9ecae1", ec="0.3")
    if judged:
        ax.axhline(judged / len(counts), color="0.2", ls="--", lw=1, label="calibrated")
        ax.legend(fontsize=7, loc="upper right")
    ax.set_xlim(0, 1)
    ax.set_xlabel("PIT of a held-out row, F(z) [1]", fontsize=8)
    ax.set_ylabel("held-out rows [count]", fontsize=8)
    shown = f"{coverage:.1%}" if judged else "no held-out row"
    ax.set_title(plain(f"{title}: {judged} held-out rows, 95 % coverage {shown}"), fontsize=8)
    ax.tick_params(labelsize=7)
    return fig


def compatibility_map(folds: list[str], table: Any, title: str):
    """The fold-compatibility map: for every pair of folds, the share of the prior points the
    common targets and both folds' rows leave (the diagonal: one fold with the common targets);
    a zero is drawn black: no bench reproduces both."""
    table = np.asarray(table, dtype=float)
    n = max(len(folds), 1)
    fig, ax = plt.subplots(figsize=(1.0 + 0.35 * n, 0.8 + 0.35 * n))
    shown = np.where(table > 0, table, np.nan)
    image = ax.imshow(
        shown, cmap="viridis", vmin=0.0, vmax=max(float(np.nanmax(table, initial=0)), 1e-9)
    )
    for i, j in zip(*np.nonzero(table == 0)):
        ax.add_patch(plt.Rectangle((j - 0.5, i - 0.5), 1, 1, color="black"))
    ax.set_xticks(range(len(folds)), [plain(f) for f in folds], rotation=90, fontsize=7)
    ax.set_yticks(range(len(folds)), [plain(f) for f in folds], fontsize=7)
    fig.colorbar(image, ax=ax, label="share of the prior points left [1]")
    ax.set_title(plain(title), fontsize=8)
    return fig


#: the posterior's verdicts and the colour of their bar
POSTERIOR_COLOURS = {
    "consistent": "#2ca02c",
    "consistent (uninformative)": "#b7d7a8",
    "inconsistent": "#d62728",
    "incompatible": "#9467bd",
}
#: the review forest's intervals, each (low, high) column of the review table
REVIEW_INTERVALS = {
    "envelope": ("envelope p2.5", "envelope p97.5"),
    "posterior": ("posterior p2.5", "posterior p97.5"),
}


def review_rows(review: pd.DataFrame, axis: tuple[float, float] = AXIS) -> pd.DataFrame:
    """The review forest's rows: the review table's rows with a posterior verdict that has a
    colour (judged and emulable) and a published value not 0, with ``label`` and each interval's
    ends, the posterior median and the nominal as deviations in % of |published|."""
    kept = review[
        review["posterior"].isin(list(POSTERIOR_COLOURS))
        & (pd.to_numeric(review["published"], errors="coerce") != 0)
    ]
    out = pd.DataFrame(
        {
            "chapter": kept["chapter"].astype(str),
            "label": [label(s, q) for s, q in zip(kept["source"], kept["quantity"])],
            "posterior": kept["posterior"].astype(str),
        },
        index=kept.index,
    )
    published = kept["published"].astype(float)
    columns = [c for pair in REVIEW_INTERVALS.values() for c in pair]
    for c in [*columns, "posterior p50", "nominal"]:
        values = pd.to_numeric(kept[c], errors="coerce")
        out[c] = np.clip(deviation(values, published), *axis)
    return out


def review_forest(review: pd.DataFrame, title: str, axis: tuple[float, float] = AXIS):
    """Every judged emergent row's two intervals on one axis of deviation from the published
    value [% of |published|]: the prior envelope's 2.5–97.5 % as a thin grey bar, the posterior
    predictive's as a bar coloured by its verdict with its median as a tick, the nominal twin
    as a black dot, the published value the line at 0 (values beyond :data:`AXIS` at its edge).
    One panel per chapter."""
    rows = review_rows(review, axis)
    fig, panels = _chapter_panels(rows, title, "no judged row with a published value other than 0")
    if not panels:
        return fig
    for ax, chapter, panel in panels:
        for y, (_, row) in enumerate(panel.iterrows()):
            lo, hi = REVIEW_INTERVALS["envelope"]
            if np.isfinite(row[lo]) and np.isfinite(row[hi]):
                ax.barh(y, row[hi] - row[lo], left=row[lo], height=0.8, color="0.85", zorder=1)
            lo, hi = REVIEW_INTERVALS["posterior"]
            colour = POSTERIOR_COLOURS[row["posterior"]]
            ax.barh(y, row[hi] - row[lo], left=row[lo], height=0.4, color=colour, zorder=2)
            ax.plot(row["posterior p50"], y, "|", ms=7, mew=1.4, color="0.15", zorder=3)
            if np.isfinite(row["nominal"]):
                ax.plot(row["nominal"], y, "o", ms=3.2, color="k", zorder=4)
        ax.axvline(0.0, color="k", lw=0.8, zorder=2)
        ax.set_yticks(range(len(panel)), [plain(t) for t in panel["label"]], fontsize=7)
        ax.set_ylim(len(panel) - 0.5, -0.5)
        ax.grid(axis="x", alpha=0.3)
        ax.set_title(_chapter_title(chapter, panel["posterior"]), fontsize=8, loc="left")
    last = panels[-1][0]
    last.set_xlim(axis[0] - 5.0, axis[1] + 5.0)
    last.set_xlabel("deviation from the published value [% of |published|]")
    fig.suptitle(plain(f"{title}\n{_numbers(len(rows))} judged"), fontsize=9)
    handles = [Patch(color="0.85", label="prior envelope p2.5–p97.5")] + [
        Patch(color=c, label=f"posterior p2.5–p97.5: {v}") for v, c in POSTERIOR_COLOURS.items()
    ]
    handles += [
        Line2D([], [], marker="|", ms=7, mew=1.4, color="0.15", ls="none", label="posterior p50"),
        Line2D([], [], marker="o", ms=3.2, color="k", ls="none", label="nominal twin"),
    ]
    fig.legend(handles=handles, loc="outside lower center", ncols=3, fontsize=7)
    return fig


def validation_figure(fig, path: str | os.PathLike, *, inputs=(), pdf: bool = True, **extra):
    """Save a validation figure (PNG, with ``pdf`` a PDF beside it) with its provenance
    (``extra``: the declaration's and the unknowns' sha256)."""
    try:
        save_figure(fig, path, inputs=inputs, pdf=pdf, **extra)
    finally:
        plt.close(fig)
