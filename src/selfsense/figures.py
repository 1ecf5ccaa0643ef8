"""Figure builders: arrays in, a matplotlib Figure out (scripts save them with provenance).

Axes are labelled with units; SI values are converted to µm, µF, ms only here, at the edge.
"""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

UM, UF = 1e6, 1e6


def _fig(nrows=1, ncols=1, **kw):
    fig, ax = plt.subplots(nrows, ncols, figsize=(6.4, 2.2 + 2.2 * nrows) if nrows > 1 else (6.4, 4.2),
                           constrained_layout=True, **kw)
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


def time_traces(t, traces: list[tuple[np.ndarray, str]], title):
    """Stacked traces sharing a time axis [s]; each trace is (values, axis label with unit)."""
    fig, axes = _fig(len(traces), 1, sharex=True)
    for ax, (values, label) in zip(np.atleast_1d(axes), traces):
        ax.plot(t, values, lw=0.8)
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
        ax.plot(t_fine * 1e6, np.cos(2 * np.pi * fr * t_fine), lw=0.5, color="0.6", label=f"ripple {fr / 1e3:g} kHz")
        ax.plot(k / plan.fs * 1e6, np.cos(2 * np.pi * fr * k / plan.fs), "o", ms=3, label="samples")
        sign = -1 if plan.mirrored else 1
        ax.plot(t_fine * 1e6, np.cos(sign * 2 * np.pi * plan.fr_folded * t_fine), lw=1,
                label=f"folded {plan.fr_folded / 1e3:.4g} kHz")
        ax.set_ylabel(f"nf = {plan.nf}\nfs = {plan.fs / 1e3:.4g} kHz")
        ax.legend(loc="upper right", fontsize=7)
    np.atleast_1d(axes)[-1].set_xlabel("time [µs]")
    np.atleast_1d(axes)[0].set_title(f"Folding of the ripple, ns = {plans[0].ns}")
    return fig


def np_study(table: pd.DataFrame):
    """C_e error against np for several ripple-frequency wanders."""
    fig, axes = _fig(1, 2)
    for wander, rows in table.groupby("wander [Hz]"):
        axes[0].plot(rows["np"], rows["rms error vs window mean [%]"], "o-", label=f"wander ±{wander:g} Hz")
        axes[1].plot(rows["np"], rows["rms error vs instantaneous [%]"], "o-", label=f"wander ±{wander:g} Hz")
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
        line, = axes[0].plot(xs[i], q_meas[i], lw=0.6, label=f"{label} measured")
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
            line, = ax.plot(q, tr["U"], lw=0.6, label=f"U, {f:g} Hz")
            ax.plot(q, tr[f"U_H case {case}"], lw=0.8, color=line.get_color(), ls="--", label=f"U_H, {f:g} Hz")
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
        ax.plot(rows["omega_S [rad/s]"] / (2 * np.pi), rows["max error [µm]"], "o-", label=f"+{offset:g} mA offset")
    ax.set(xscale="log", xlabel="transition frequency ω_S/2π [Hz]", ylabel="max observer error [µm]",
           title="Hybrid position observer: transition frequency against offset current")
    ax.grid(alpha=0.3, which="both")
    ax.legend()
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


def placeholder(title: str, reason: str):
    """A figure that says why its content could not be computed for this campaign or dataset."""
    fig, ax = _fig()
    ax.text(0.5, 0.5, reason, ha="center", va="center", wrap=True)
    ax.set(title=title, xticks=[], yticks=[])
    return fig
