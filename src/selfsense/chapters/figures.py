"""Figure builders: arrays in, a matplotlib Figure out (scripts save them with provenance).

Axes are labelled with units; SI values are converted to µm, µF, ms only here, at the edge.
"""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
# Agg rasterises a line path in one piece by default, and its memory grows with the path's length
# in pixels: a 12 000-point C_e–x scribble (Fig 7.7 of a 600 s run) took 300 MB to save as PNG,
# so a longer capture made a bigger figure job. Chunks of 1000 vertices bound it (≈ 40 MB).
matplotlib.rcParams["agg.path.chunksize"] = 1000
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

UM, UF = 1e6, 1e6


def _fig(nrows=1, ncols=1, **kw):
    fig, ax = plt.subplots(
        nrows,
        ncols,
        figsize=(6.4, 2.2 + 2.2 * nrows) if nrows > 1 else (6.4, 4.2),
        constrained_layout=True,
        **kw,
    )
    return fig, ax


def loop(x, y, xlabel, ylabel, title, labels=None):
    """One or more loops y(x): x and y are arrays or lists of arrays (one per label)."""
    fig, ax = _fig()
    xs, ys = (x, y) if isinstance(x, list) else ([x], [y])
    for i, (a, b) in enumerate(zip(xs, ys)):
        ax.plot(a, b, lw=0.8, label=None if labels is None else labels[i])
    ax.set(xlabel=xlabel, ylabel=ylabel, title=title)
    if labels is not None:
        ax.legend()
    ax.grid(alpha=0.3)
    return fig


#: a loop panel of fewer points draws them larger
SPARSE_POINTS = 5000


def loop_grid(rows, title):
    """One row of loops per item: rows are (name, panels) with panels (x, y, xlabel, ylabel) or
    (x, y, xlabel, ylabel, groups): ``groups`` None (all points alike) or {legend: (mask,
    colour)}, drawn in its order, each later group on top of the earlier ones (zorder), with a
    legend in the row's first panel."""
    ncols = max(len(panels) for _, panels in rows)
    fig, axes = plt.subplots(
        len(rows),
        ncols,
        figsize=(3.6 * ncols + 0.6, 2.6 * len(rows) + 0.6),
        constrained_layout=True,
        squeeze=False,
    )
    for ax_row, (name, panels) in zip(axes, rows):
        for ax in ax_row[len(panels) :]:
            ax.axis("off")
        for ax, (x, y, xlabel, ylabel, *rest) in zip(ax_row, panels):
            # points, not a line: thinned to the figure's resolution, a long run at a fast drive
            # keeps about one point per cycle, and a line through them crosses the panel at every
            # sample (a scribble that hid the loop and took Agg 1 s a panel to fill); raster in the
            # PDF too
            groups = rest[0] if rest else None
            ms = 1.0 if len(x) > SPARSE_POINTS else 2.5  # a short record's points stay visible
            if groups is None:
                ax.plot(x, y, ".", ms=ms, mew=0, rasterized=True)
            else:
                for z, (label, (mask, colour)) in enumerate(groups.items()):
                    ax.plot(
                        x[mask],
                        y[mask],
                        ".",
                        ms=ms,
                        mew=0,
                        color=colour,
                        label=label,
                        zorder=2 + z,
                        rasterized=True,
                    )
                if ax is ax_row[0] and len(groups) > 1:
                    # the legend's markers large enough to tell the colours apart
                    ax.legend(fontsize=6, markerscale=4 / ms, loc="best", framealpha=0.8)
            ax.set(xlabel=xlabel, ylabel=ylabel)
            ax.grid(alpha=0.3)
        ax_row[0].set_title(name, fontsize=9)
    fig.suptitle(title)
    return fig


def time_traces(t, traces: list[tuple[np.ndarray | dict[str, np.ndarray], str]], title):
    """Stacked panels sharing a time axis [s]; each is (values, axis label with unit), values an
    array or {legend: array} for several traces in one panel."""
    fig, axes = _fig(len(traces), 1, sharex=True)
    for ax, (values, label) in zip(np.atleast_1d(axes), traces):
        for name, v in values.items() if isinstance(values, dict) else [(None, values)]:
            ax.plot(t, v, lw=0.8, label=name)
        if isinstance(values, dict):
            ax.legend(fontsize=7)
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
    np.atleast_1d(axes)[0].set_title(title)
    np.atleast_1d(axes)[-1].set_xlabel("time [s]")
    return fig


def normalised_pair(t, u, i, title, t_unit="s", scale=1.0):
    """Voltage and current normalised by their peak magnitude (Figs 3.3, 3.4)."""
    fig, ax = _fig()
    ax.plot(t * scale, u / np.max(np.abs(u)), label="voltage (normalised)")
    ax.plot(t * scale, i / np.max(np.abs(i)), label="current (normalised)")
    ax.set(xlabel=f"time [{t_unit}]", ylabel="normalised amplitude [-]", title=title)
    ax.legend(loc="upper right")
    ax.grid(alpha=0.3)
    return fig


def folding(fr: float, plans, periods: float = 2.5):
    """Fig 3.7: a ripple sampled with 0–3 folds, the samples tracing the folded frequency."""
    fig, axes = _fig(len(plans), 1)
    for ax, plan in zip(np.atleast_1d(axes), plans):
        duration = periods / plan.fr_folded
        t_fine = np.linspace(0, duration, 4000)
        k = np.arange(int(duration * plan.fs) + 1)
        ax.plot(
            t_fine * 1e6,
            np.cos(2 * np.pi * fr * t_fine),
            lw=0.5,
            color="0.6",
            label=f"ripple {fr / 1e3:g} kHz",
        )
        ax.plot(k / plan.fs * 1e6, np.cos(2 * np.pi * fr * k / plan.fs), "o", ms=3, label="samples")
        sign = -1 if plan.mirrored else 1
        ax.plot(
            t_fine * 1e6,
            np.cos(sign * 2 * np.pi * plan.fr_folded * t_fine),
            lw=1,
            label=f"folded {plan.fr_folded / 1e3:.4g} kHz",
        )
        ax.set_ylabel(f"nf = {plan.nf}\nfs = {plan.fs / 1e3:.4g} kHz")
        ax.legend(loc="upper right", fontsize=7)
    np.atleast_1d(axes)[-1].set_xlabel("time [µs]")
    np.atleast_1d(axes)[0].set_title(f"Folding of the ripple, ns = {plans[0].ns}")
    return fig


def np_study(table: pd.DataFrame):
    """C_e error against np for several ripple-frequency wanders."""
    fig, axes = _fig(1, 2)
    for wander, rows in table.groupby("wander [Hz]"):
        axes[0].plot(
            rows["np"], rows["rms error vs window mean [%]"], "o-", label=f"wander ±{wander:g} Hz"
        )
        axes[1].plot(
            rows["np"], rows["rms error vs instantaneous [%]"], "o-", label=f"wander ±{wander:g} Hz"
        )
    axes[0].set(xlabel="np [periods]", ylabel="rms C_e error [%]", title="vs C_P over the window")
    axes[1].set(xlabel="np [periods]", ylabel="rms C_e error [%]", title="vs C_P at window centre")
    for ax in axes:
        ax.set_xscale("log", base=2)
        ax.grid(alpha=0.3)
    axes[1].legend(fontsize=7)
    return fig


def velocity_response(t, traces: dict[str, np.ndarray], title):
    fig, ax = _fig()
    for label, v in traces.items():
        ax.plot(t * 1e6, v * 1e3, label=label)
    ax.set(xlabel="time [µs]", ylabel="velocity [mm/s]", title=title)
    ax.legend()
    ax.grid(alpha=0.3)
    return fig


def model_vs_measured(xs, q_meas, q_model, i_meas, i_model, labels):
    """Fig 4.6: (a) charge–position and (b) current–position, measured and modelled."""
    fig, axes = _fig(1, 2)
    for i, label in enumerate(labels):
        (line,) = axes[0].plot(xs[i], q_meas[i], lw=0.6, label=f"{label} measured")
        axes[0].plot(xs[i], q_model[i], "--", lw=1, color=line.get_color(), label=f"{label} model")
        axes[1].plot(xs[i], np.asarray(i_meas[i]) * 1e3, lw=0.6, color=line.get_color())
        axes[1].plot(xs[i], np.asarray(i_model[i]) * 1e3, "--", lw=1, color=line.get_color())
    axes[0].set(xlabel="x [µm]", ylabel="q [µC]", title="(a) charge–position")
    axes[1].set(xlabel="x [µm]", ylabel="I [mA]", title="(b) current–position")
    axes[0].legend(fontsize=6)
    for ax in axes:
        ax.grid(alpha=0.3)
    return fig


def model_comparison(panels):
    """Fig 4.7: traditional vs proposed charge–position fit and their errors, per frequency."""
    fig, axes = _fig(2, max(1, len(panels)), squeeze=False)
    for col, (f, p) in enumerate(panels.items()):
        x = p["x"] * UM
        axes[0, col].plot(x, p["q"] * 1e6, lw=0.6, label="measured")
        axes[0, col].plot(x, p["traditional"] * 1e6, "--", label="traditional (ΔCx = 0)")
        axes[1, col].plot(x, p["error traditional"] * 1e6, lw=0.6, label="traditional")
        axes[0, col].plot(x, p["proposed"] * 1e6, ":", label="proposed (ΔCx < 0)")
        axes[1, col].plot(x, p["error proposed"] * 1e6, lw=0.6, label="proposed")
        axes[0, col].set(title=f"{f:g} Hz", ylabel="q [µC]")
        axes[1, col].set(xlabel="x [µm]", ylabel="charge error [µC]")
        for ax in axes[:, col]:
            ax.grid(alpha=0.3)
            ax.legend(fontsize=7)
    return fig


def hysteresis_voltage(traces):
    """Fig 4.8: U and U_H against charge for both models, per frequency."""
    fig, axes = _fig(1, 2)
    for f, tr in traces.items():
        q = tr["q"] * 1e6
        for ax, case in zip(axes, (1, 2)):
            (line,) = ax.plot(q, tr["U"], lw=0.6, label=f"U, {f:g} Hz")
            ax.plot(
                q,
                tr[f"U_H case {case}"],
                lw=0.8,
                color=line.get_color(),
                ls="--",
                label=f"U_H, {f:g} Hz",
            )
    axes[0].set(title="(a) traditional model (ΔCx = 0)")
    axes[1].set(title="(b) proposed model (ΔCx < 0)")
    for ax in axes:
        ax.set(xlabel="q [µC]", ylabel="voltage [V]")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    return fig


def observer_study(table):
    """Observer max error against ω_S for several added offset currents."""
    fig, ax = _fig()
    for offset, rows in table.groupby("added offset [mA]"):
        ax.plot(
            rows["omega_S [rad/s]"] / (2 * np.pi),
            rows["max error [µm]"],
            "o-",
            label=f"+{offset:g} mA offset",
        )
    ax.set(
        xscale="log",
        xlabel="transition frequency ω_S/2π [Hz]",
        ylabel="max observer error [µm]",
        title="Hybrid position observer: transition frequency against offset current",
    )
    ax.grid(alpha=0.3, which="both")
    ax.legend()
    return fig


def error_budget(table, sources):
    """The observer's error budget: per run, the rms of each source stacked, with the error's rms
    and max marked (stacked rms exceed the total's where sources cancel: the cross terms)."""
    fig, ax = _fig()
    runs = np.arange(len(table))
    bottom = np.zeros(len(table))
    for source in sources:
        height = table[f"{source} rms [µm]"].to_numpy()
        ax.bar(runs, height, 0.6, bottom=bottom, label=source)
        bottom += height
    ax.plot(runs, table["total rms [µm]"], "k_", ms=22, mew=2, label="error rms")
    ax.plot(runs, table["total max error [µm]"], "kv", label="error max (Tables 5.4, 6.1, 6.2)")
    labels = [
        f"{f:g} Hz" if np.isfinite(f) else f"{run} {segment}" if isinstance(segment, str) else run
        for run, f, segment in zip(table["run"], table["frequency [Hz]"], table["segment"])
    ]
    ax.set_xticks(runs, labels, rotation=30, ha="right", fontsize=7)
    ax.set(ylabel="rms over the run [µm]", title="Observer error budget against the twin's truth")
    ax.grid(alpha=0.3, axis="y")
    ax.legend(fontsize=7, ncols=4, loc="upper center", bbox_to_anchor=(0.5, -0.2))
    return fig


def magnitude_plot(freqs_hz, curves: dict, title):
    """Fig 5.10: magnitude of transfer functions [dB] against frequency."""
    fig, ax = _fig()
    for label, mag in curves.items():
        ax.semilogx(freqs_hz, 20 * np.log10(np.maximum(np.abs(mag), 1e-300)), label=label)
    ax.set(xlabel="frequency [Hz]", ylabel="magnitude [dB] (x̂/I0 in m/A)", title=title)
    ax.grid(alpha=0.3, which="both")
    ax.legend()
    return fig


def bode(table: pd.DataFrame, model_f, model_G, peaks: pd.DataFrame, thesis_hz: float, title):
    """Fig 5.3: measured points against the model line, magnitude and phase; resonances marked.

    ``table`` has the measured columns of
    :func:`selfsense.methods.frequency_response.response_table`, ``model_G`` is complex on
    ``model_f`` [Hz] (m/C, numerically µm/µC), ``peaks`` is
    :func:`~selfsense.methods.frequency_response.resonance_table`.
    """
    fig, (mag, phase) = _fig(2, 1, sharex=True)
    f = table["frequency [Hz]"]
    mag.loglog(model_f, np.abs(model_G), "-", lw=1, label="model, Eq 5.2 (identified parameters)")
    mag.loglog(f, table["measured |G| [µm/µC]"], "o", ms=3, label="measured (stepped sine)")
    phase.semilogx(model_f, np.degrees(np.unwrap(np.angle(model_G))), "-", lw=1)
    phase.semilogx(f, np.degrees(np.unwrap(np.radians(table["measured phase [deg]"]))), "o", ms=3)
    for (_, row), style in zip(peaks.iterrows(), ("--", ":")):
        if np.isfinite(row["peak frequency [Hz]"]):
            for ax in (mag, phase):
                ax.axvline(row["peak frequency [Hz]"], ls=style, lw=0.8, color="gray")
            mag.annotate(
                f"{row['response']} peak {row['peak frequency [Hz]']:.0f} Hz",
                (row["peak frequency [Hz]"], row["peak |G| [µm/µC]"]),
                fontsize=7,
                xytext=(-4, -12 - 10 * (style == ":")),
                textcoords="offset points",
                ha="right",
            )
    for ax in (mag, phase):
        ax.axvline(thesis_hz, ls="-.", lw=0.8, color="tab:red")
        ax.grid(alpha=0.3, which="both")
    mag.annotate(
        f"thesis ≈ {thesis_hz:g} Hz",
        (thesis_hz, mag.get_ylim()[1]),
        fontsize=7,
        color="tab:red",
        xytext=(3, -10),
        textcoords="offset points",
    )
    mag.set(ylabel="|G| = |x/q| [µm/µC]", title=title)
    phase.set(xlabel="frequency [Hz]", ylabel="phase [deg]")
    mag.legend(fontsize=7, loc="upper left")
    return fig


def placeholder(title: str, reason: str):
    """A figure that says why its content could not be computed for this campaign or dataset."""
    fig, ax = _fig()
    ax.text(0.5, 0.5, reason, ha="center", va="center", wrap=True)
    ax.set(title=title, xticks=[], yticks=[])
    return fig


def frequency_effect(curves, gamma_curve: tuple[np.ndarray, np.ndarray], max_points: int = 3000):
    """Fig 7.8: (a) C_e against x per drive frequency over Γ; (b) each curve's distance from Γ.

    ``curves``: {label: {"x", "C_e", "centres", "rising", "falling"}} with raw ripple windows
    (thinned to ``max_points`` for drawing) and the binned x − Γ(C_e) per branch;
    ``gamma_curve``: (C, Γ(C)) in SI units.
    """
    fig, axes = _fig(1, 2)
    for label, c in curves.items():
        step = max(1, len(c["x"]) // max_points)
        colour = (
            axes[0]
            .plot(c["x"][::step] * UM, c["C_e"][::step] * UF, ".", ms=1, alpha=0.4)[0]
            .get_color()
        )
        axes[0].plot([], [], "o", color=colour, label=label)
        axes[1].plot(c["centres"] * UM, c["rising"] * UM, ".-", color=colour, lw=0.9, ms=3)
        axes[1].plot(c["centres"] * UM, c["falling"] * UM, ".--", color=colour, lw=0.9, ms=3)
    axes[0].plot(gamma_curve[1] * UM, gamma_curve[0] * UF, "k-", lw=1, label="Γ (0.1 Hz fit)")
    axes[0].set(xlabel="x [µm]", ylabel="C_e [µF]", title="(a) capacitance against position")
    axes[1].axhline(0, color="k", lw=0.8)
    axes[1].set(
        xlabel="x [µm]",
        ylabel="x − Γ(C_e) [µm]",
        title="(b) distance from Γ, binned\n(solid: rising, dashed: falling)",
    )
    axes[0].legend(fontsize=7)
    for ax in axes:
        ax.grid(alpha=0.3)
    return fig


def _boundary(block: dict, toward) -> np.ndarray:
    """Where a wire from the block's centre towards ``toward`` leaves the block's outline."""
    c, d = (
        np.asarray(block["xy"], float),
        np.asarray(toward, float) - np.asarray(block["xy"], float),
    )
    if not np.any(d):
        return c
    if block.get("kind", "box") in ("sum", "mul"):
        return c + d / np.hypot(*d) * block.get("r", 1.8)
    w, h = block.get("size", (0.0, 0.0))
    scale = min(0.5 * w / abs(d[0]) if d[0] else np.inf, 0.5 * h / abs(d[1]) if d[1] else np.inf)
    return c + d * min(scale, 1.0)


def block_diagram(panels, width: float = 12.0, extent: tuple[float, float] = (104.0, 46.0)):
    """Signal-flow diagrams, one panel each, drawn in data coordinates (0..extent).

    ``panels``: [(title, blocks, wires)]. ``blocks``: {name: {"xy", "text", "kind", "size" | "r"}}
    with kind "box" (framed text of ``size`` (w, h)), "port" (unframed text of ``size``: where a
    signal enters or leaves), "node" (a branch point), "sum" (Σ circle) or "mul" (× circle).
    ``wires``: [(from, to, label, via, sign)] drawn as straight segments through the ``via``
    points, the arrow at ``to``; ``label`` names the signal beside its longest segment and
    ``sign`` ("+", "−") is written where the wire enters a summing junction.
    """
    fig, axes = plt.subplots(
        len(panels),
        1,
        figsize=(width, width * extent[1] / extent[0] * len(panels)),
        constrained_layout=True,
        squeeze=False,
    )
    for ax, (title, blocks, wires) in zip(axes[:, 0], panels):
        ax.set(xlim=(0, extent[0]), ylim=(0, extent[1]), aspect="equal", title=title)
        ax.axis("off")
        for b in blocks.values():
            kind = b.get("kind", "box")
            if kind in ("sum", "mul"):
                ax.add_patch(plt.Circle(b["xy"], b.get("r", 1.8), fill=False, lw=1))
                ax.text(
                    *b["xy"], "Σ" if kind == "sum" else "×", ha="center", va="center", fontsize=10
                )
            elif kind == "node":
                ax.plot(*b["xy"], "ko", ms=3)
            else:
                w, h = b["size"]
                if kind == "box":
                    ax.add_patch(
                        plt.Rectangle(
                            (b["xy"][0] - w / 2, b["xy"][1] - h / 2), w, h, fill=False, lw=1
                        )
                    )
                ax.text(
                    *b["xy"], b["text"], ha="center", va="center", fontsize=7.5, linespacing=1.3
                )
        for src, dst, label, via, sign in wires:
            pts = [blocks[src]["xy"], *via, blocks[dst]["xy"]]
            pts[0], pts[-1] = _boundary(blocks[src], pts[1]), _boundary(blocks[dst], pts[-2])
            if len(pts) > 2:
                ax.plot(*zip(*pts[:-1]), "k-", lw=0.9)
            ax.annotate(
                "",
                xy=pts[-1],
                xytext=pts[-2],
                arrowprops={"arrowstyle": "-|>", "lw": 0.9, "color": "k"},
            )
            if label:  # beside the longest segment, above it or to its right
                (x0, y0), (x1, y1) = max(
                    zip(pts[:-1], pts[1:]), key=lambda seg: np.hypot(*np.subtract(*seg))
                )
                vertical = abs(x1 - x0) < abs(y1 - y0)
                ax.text(
                    (x0 + x1) / 2 + (0.8 if vertical else 0),
                    (y0 + y1) / 2 + (0 if vertical else 0.8),
                    label,
                    ha="left" if vertical else "center",
                    va="center" if vertical else "bottom",
                    fontsize=8.5,
                )
            if sign:  # right of the arrow's direction, so it keeps clear of the labels
                end, before = np.asarray(pts[-1]), np.asarray(pts[-2])
                d = (end - before) / np.hypot(*(end - before))
                ax.text(
                    *(end - 1.6 * d + 1.3 * np.array([d[1], -d[0]])),
                    sign,
                    ha="center",
                    va="center",
                    fontsize=9,
                )
    return fig
