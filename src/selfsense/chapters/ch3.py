"""Chapter 3: ripple impedance measurement — hysteresis table and Figures 3.2–3.14."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import pandas as pd
from scipy import signal

from selfsense.chapters import figure_names, figures
from selfsense.io.capture import open_capture
from selfsense.methods.metrics import direction, hysteresis_percent
from selfsense.methods.ripple import SamplingPlan

#: (horizontal, vertical, thesis's value [%], the thesis's words)
LOOPS = (
    ("U", "C_e", 10.0, "C–V hysteresis ≈ 10 % of the voltage (Fig 3.10)"),
    ("x_laser", "C_e", 3.0, "C–x hysteresis minimal, < 3 % (Fig 3.11)"),
    ("C_e", "R_e", 6.25, "R–C hysteresis 6.25 % (Fig 3.14)"),
    ("U", "x_laser", float("nan"), "x–U hysteresis large (Fig 3.12)"),
)
LABEL = {"U": "U [V]", "C_e": "C_e [µF]", "R_e": "R_e [Ω]", "x_laser": "x [µm]"}
SCALE = {"U": 1.0, "C_e": 1e6, "R_e": 1.0, "x_laser": 1e6}
#: drive frequency [Hz] of the run most figures show, and the end of its capture Fig 3.3 shows [s]
SHOWN_HZ = 10.0
SHOWN_TAIL_S = 0.2
#: file names of the figures :func:`figures_ch3` builds, in its order
FIGURES, MODEL_FIGURE = figure_names.CH3, figure_names.CH3_MODEL


def steady(series: Mapping[str, np.ndarray], skip: float) -> dict[str, np.ndarray]:
    """The series after its first ``skip`` seconds (the first cycle starts from the virgin
    state)."""
    keep = series["time"] >= skip
    return {k: np.asarray(v)[keep] for k, v in series.items()}


def hysteresis_table(series: Mapping[str, np.ndarray]) -> pd.DataFrame:
    """Loop widths of C–U, C–x, R–C and x–U at 100 V, 10 Hz, beside the thesis's values."""
    rising = direction(series["U"])
    rows = []
    for h, v, published, words in LOOPS:
        along_v, along_h = hysteresis_percent(series[h], series[v], rising)
        rows.append(
            {
                "loop": f"{v}–{h}",
                "thesis [%]": published,
                "thesis says": words,
                "width along horizontal [% of range]": along_h,
                "width along vertical [% of range]": along_v,
            }
        )
    return pd.DataFrame(rows)


def phase_deg(t: np.ndarray, u: np.ndarray, i: np.ndarray, f: float) -> float:
    """Phase by which i leads u at frequency f, from least-squares sinusoid fits."""
    basis = np.column_stack([np.cos(2 * np.pi * f * t), np.sin(2 * np.pi * f * t), np.ones_like(t)])
    (ua, ub, _), (ia, ib, _) = (np.linalg.lstsq(basis, y, rcond=None)[0] for y in (u, i))
    return float(np.degrees(np.angle((ia - 1j * ib) / (ua - 1j * ub))))


def ripple_phase_deg(series: Mapping[str, np.ndarray]) -> float:
    """Median phase by which the ripple current leads the ripple voltage (Fig 3.4)."""
    current = series["B_I"] - 1j * series["A_I"]
    voltage = series["B_V"] - 1j * series["A_V"]
    return float(np.degrees(np.median(np.angle(current / voltage))))


def phase_table(series: Mapping[str, np.ndarray], f: float) -> pd.DataFrame:
    """The phases Figs 3.3–3.4 print in their titles: by how much the drive current leads the
    drive voltage at the drive frequency ``f`` [Hz], and the ripple current the ripple voltage."""
    return pd.DataFrame(
        [
            {
                "signal": "drive",
                "frequency [Hz]": f,
                "current leads voltage by [°]": phase_deg(
                    series["time"], series["U"], series["I"], f
                ),
            },
            {
                "signal": "ripple",
                "frequency [Hz]": float("nan"),
                "current leads voltage by [°]": ripple_phase_deg(series),
            },
        ]
    )


def figure_3_2(stack: Mapping[str, float], ripple_amplitude: float, fr: float):
    """Ripple-driven velocity of the stack free (≈ 40 kHz) and clamped in the bench (2.5 kHz).

    A model figure: the force α·U_r at fr through m ẍ + b ẋ + k x, for the two mounted masses.
    """
    k, alpha, zeta = stack["k"], stack["alpha"], stack["zeta"]
    t = np.linspace(0, 3 / fr, 600)
    traces = {}
    for label, f_n in (
        ("free (40 kHz)", 40e3),
        (f"clamped in the bench ({stack['f_bench'] / 1e3:g} kHz)", stack["f_bench"]),
    ):
        m = k / (2 * np.pi * f_n) ** 2
        velocity_per_force = signal.TransferFunction([1, 0], [m, 2 * zeta * np.sqrt(k * m), k])
        _, h = signal.freqresp(velocity_per_force, [2 * np.pi * fr])
        traces[label] = (
            np.abs(h[0]) * alpha * ripple_amplitude * np.cos(2 * np.pi * fr * t + np.angle(h[0]))
        )
    return figures.velocity_response(
        t,
        traces,
        f"Velocity driven by a {ripple_amplitude * 1e3:g} mV, {fr / 1e3:g} kHz ripple (model)",
    )


def figures_ch3(
    capture, series_by_label: Mapping[str, Mapping[str, np.ndarray]], fr: float, ns: int
) -> dict:
    """Figures 3.3, 3.4, 3.7 and 3.9–3.14: ``capture`` is the :data:`SHOWN_HZ` run,
    ``series_by_label`` the steady ripple series by label, that run's first; ``fr`` [Hz] and ``ns``
    the DAQ's ripple plan."""
    with open_capture(capture, require=("U", "I")) as cap:
        start = max(0, cap.n - int(SHOWN_TAIL_S * cap.fs))
        last = cap.read(("U", "I"), start)
        t = (start + np.arange(len(last["U"]))) / cap.fs
    shown = next(iter(series_by_label.values()))
    one = {f"{SHOWN_HZ:g} Hz": shown}
    return dict(
        zip(
            FIGURES,
            (
                figure_3_3(t, last["U"], last["I"], SHOWN_HZ),
                figure_3_4(shown, fr),
                figure_3_7(fr, ns),
                figure_3_9(shown),
                loop_figure(one, "U", "C_e", "Effective capacitance against voltage"),
                loop_figure(one, "x_laser", "C_e", "Effective capacitance against position"),
                loop_figure(one, "U", "x_laser", "Position against voltage"),
                loop_figure(
                    series_by_label,
                    "x_laser",
                    "C_e",
                    "Effective capacitance against position at several frequencies",
                ),
                loop_figure(
                    one, "C_e", "R_e", "Effective resistance against effective capacitance"
                ),
            ),
        )
    )


def figure_3_3(t, u, i, f):
    return figures.normalised_pair(
        t - t[0],
        u - u.mean(),
        i - i.mean(),
        f"U and I at {f:g} Hz: current leads by {phase_deg(t, u, i, f):.1f}°",
    )


def figure_3_4(series, fr):
    phase = ripple_phase_deg(series)
    t = np.linspace(0, 2 / fr, 400)
    return figures.normalised_pair(
        t,
        np.cos(2 * np.pi * fr * t),
        np.cos(2 * np.pi * fr * t + np.radians(phase)),
        f"Ripple U_r and I_r at {fr / 1e3:g} kHz (from the Fourier phasors): "
        f"current leads by {phase:.1f}°",
        t_unit="µs",
        scale=1e6,
    )


def figure_3_7(fr: float, ns: int):
    return figures.folding(fr, [SamplingPlan(fr, ns, nf, 1) for nf in range(4)])


def loop_figure(
    series_by_label: Mapping[str, Mapping[str, np.ndarray]], h: str, v: str, title: str
):
    labels = list(series_by_label)
    return figures.loop(
        [series_by_label[k][h] * SCALE[h] for k in labels],
        [series_by_label[k][v] * SCALE[v] for k in labels],
        LABEL[h],
        LABEL[v],
        title,
        labels=labels if len(labels) > 1 else None,
    )


def figure_3_9(series):
    return figures.time_traces(
        series["time"],
        [
            (series["U"], LABEL["U"]),
            (series["x_laser"] * 1e6, LABEL["x_laser"]),
            (series["C_e"] * 1e6, LABEL["C_e"]),
            (series["R_e"], LABEL["R_e"]),
        ],
        "Voltage, position, effective capacitance and resistance at 10 Hz",
    )
