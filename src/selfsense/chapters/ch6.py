"""Chapter 6: closed-loop control with HPO feedback — Tables 6.1–6.2, the audit, Figures 6.2–6.8.

Error names as in the thesis: ε_O = x_laser − x̂ (observer), ε_C = x_R − x̂ (controller),
ε_T = x_R − x_laser (total); OL/CL = open/closed loop.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
import pandas as pd

from selfsense.chapters import figure_names
from selfsense.io.capture import open_capture
from selfsense.io.manifest import protocol_duration
from selfsense.methods.control import IntegralController, tracking_prediction
from selfsense.methods.drive import drive_from_protocol
from selfsense.methods.ripple import WindowMeans, plan_from_capture

SEGMENTS = "abcdefgh"
#: Drive frequencies [Hz] of the Chapter 6 profiles and their amplitude [m] (a 30 µm stroke, the
#: stroke Table 6.2's "% of stroke" refers to), where the loop's tracking is predicted.
TRACKING_FREQUENCIES_HZ = (10.0, 15.0, 40.0, 50.0, 75.0, 100.0, 125.0)
TRACKING_AMPLITUDE = 15e-6
#: Settling time after each reference step, in closed-loop time constants 1/ω_C.
SETTLE_TIME_CONSTANTS = 5
THESIS_TABLE_6_1 = {  # error: (max, mean, σ) per segment a–h [µm]
    "e_TOL": (
        (0.89, 3.08, 0.89, 1.75, 1.73, 1.62, 0.76, 1.85),
        (0.54, 2.69, 0.60, 1.38, 1.33, 1.34, 0.48, 1.52),
        (0.15, 0.16, 0.14, 0.14, 0.17, 0.15, 0.10, 0.17),
    ),
    "e_TCL": (
        (0.83, 0.99, 0.83, 0.82, 0.89, 0.66, 0.95, 0.63),
        (0.45, 0.78, 0.58, 0.34, 0.40, 0.36, 0.63, 0.31),
        (0.18, 0.14, 0.17, 0.15, 0.17, 0.11, 0.17, 0.13),
    ),
    "e_OCL": (
        (0.78, 0.93, 0.85, 0.90, 0.78, 0.64, 0.92, 0.84),
        (0.41, 0.72, 0.56, 0.44, 0.39, 0.38, 0.58, 0.40),
        (0.18, 0.14, 0.15, 0.15, 0.14, 0.11, 0.16, 0.14),
    ),
}
THESIS_TABLE_6_2 = {  # profile: {error: (µm, % of stroke)}
    "P2a": {
        "e_OCL": (0.82, 2.74),
        "e_CCL": (0.69, 2.3),
        "e_TCL": (1.46, 4.86),
        "e_TOL": (3.51, 11.72),
    },
    "P2b": {
        "e_OCL": (0.92, 3.08),
        "e_CCL": (9.84, 32.82),
        "e_TCL": (9.7, 32.34),
        "e_TOL": (6.93, 23.11),
    },
    "P2c": {
        "e_OCL": (0.91, 3.04),
        "e_CCL": (2.32, 7.74),
        "e_TCL": (2.81, 9.29),
        "e_TOL": (4.52, 15.08),
    },
    "P2d": {
        "e_OCL": (0.89, 2.95),
        "e_CCL": (4.42, 14.74),
        "e_TCL": (4.74, 15.81),
        "e_TOL": (5.86, 19.54),
    },
}


def p1_window(protocol: Mapping, tests: int = 2) -> float:
    """The end [s] of P1's first ``tests`` tests: its warm-up and as many passes through a–h."""
    return protocol_duration(dict(protocol, repeat=tests))


def load_run(path, protocol: Mapping, command: bool = False) -> dict[str, np.ndarray | None]:
    """One run's means over one folded ripple period (the real-time loop's 4 kHz rate): U, x_laser
    (zeroed at the start), x_R (logged, else the protocol's), in closed loop the logged x̂ and, with
    ``command``, the loop's logged drive command u_cmd (None in open loop)."""
    with open_capture(path, require=("U", "x_laser")) as cap:
        logged = ("x_ref", "x_hpo_rt", "u_cmd") if command else ("x_ref", "x_hpo_rt")
        names = [c for c in ("U", "x_laser", *logged) if c in cap.channels]
        plan = plan_from_capture(cap, 1)
        means = WindowMeans(plan, len(names))
        parts = [means.process(*(d[c] for c in names)) for _, d in cap.iter_chunks(names)]
        fs = cap.fs
    index = np.concatenate([p[0] for p in parts])
    values = dict(zip(names, np.concatenate([p[1] for p in parts], axis=1)))
    t = (index - (plan.ns - 1) / 2) / fs
    run = {"t": t, "U": values["U"], "x_laser": values["x_laser"] - values["x_laser"][0]}
    run["x_ref"] = values["x_ref"] if "x_ref" in values else drive_from_protocol(protocol)(t)
    run["x_hat"] = values.get("x_hpo_rt")
    if command:
        run["u_cmd"] = values.get("u_cmd")
    return run


def results(
    runs: Mapping[str, Mapping[str, np.ndarray]],
    protocols: Mapping[str, Mapping],
    profiles: Mapping[str, tuple[str, str]],
    k_over_alpha: float,
    omega_c: float,
) -> dict[str, pd.DataFrame]:
    """Tables 6.1 (P1 tests), 6.2 (P2 profiles), the P3 summary and the loop's tracking
    prediction, from the runs of ``profiles`` ({"P1", "P2a" … "P3": (open-loop run, closed-loop
    run)})."""
    p1 = {"e_TOL": [], "e_TCL": [], "e_OCL": []}
    rows62, p1_stroke = [], 0.0
    for profile, pair in profiles.items():
        for name, closed in zip(pair, (False, True), strict=True):
            run, protocol = runs[name], protocols[name]
            if profile == "P1":
                errs = errors(
                    run["x_ref"], run["x_laser"], run["x_hat"] if closed else None, closed
                )
                per_test = len(protocol["segments"])  # the recording holds the tests in turn
                for key, maxima in segment_maxima(
                    run["t"], errs, segment_windows(protocol, omega_c)
                ).items():
                    if key in p1:
                        p1[key] += [
                            maxima[k : k + per_test] for k in range(0, len(maxima), per_test)
                        ]
                p1_stroke = max(p1_stroke, float(np.ptp(run["x_ref"])))
            elif profile.startswith("P2"):
                rows62 += p2_rows(profile, run, protocol, closed, omega_c)
    (p3o, p3c), p3 = profiles["P3"], protocols[profiles["P3"][1]]
    p3o, p3c = runs[p3o], runs[p3c]
    hold = float(p3.get("warmup", 0.0)) + p3["segments"][0]["duration"]
    t61 = table_6_1(p1)
    return {
        "table_6_1": t61,
        "p1_summary": p1_summary(t61, p1_stroke),
        "table_6_2": pd.DataFrame(rows62),
        "p3": p3_summary(p3c["t"], p3o, p3c, hold),
        "tracking": tracking_prediction(
            IntegralController(omega_c, k_over_alpha), TRACKING_FREQUENCIES_HZ, TRACKING_AMPLITUDE
        ),
    }


def errors(
    x_ref: np.ndarray, x_laser: np.ndarray, x_hat: np.ndarray | None, closed: bool
) -> dict[str, np.ndarray]:
    """The thesis's error signals for one run (positions zeroed at the run's start)."""
    loop = "CL" if closed else "OL"
    out = {f"e_T{loop}": x_ref - x_laser}
    if x_hat is not None:
        out[f"e_O{loop}"] = x_laser - x_hat
        out[f"e_C{loop}"] = x_ref - x_hat
    return out


def segment_windows(protocol: Mapping, omega_c: float) -> list[tuple[str, float, float]]:
    """P1's steady windows in the recording's order, every test's segments a–h one after another:
    (segment, start + the loop's settling SETTLE_TIME_CONSTANTS/ω_C, end) [s]."""
    warmup, segments = float(protocol.get("warmup", 0.0)), protocol["segments"]
    ends = warmup + np.cumsum([s["duration"] for s in segments] * int(protocol.get("repeat", 1)))
    starts = np.concatenate([[warmup], ends[:-1]]) + SETTLE_TIME_CONSTANTS / omega_c
    return [
        (SEGMENTS[k % len(segments)], float(a), float(b))
        for k, (a, b) in enumerate(zip(starts, ends))
    ]


def segment_maxima(
    t: np.ndarray, errs: Mapping[str, np.ndarray], windows: Sequence[tuple[str, float, float]]
) -> dict[str, list[float]]:
    """Per error signal, the max |ε| in each steady window [start, end) of
    :func:`segment_windows`."""
    return {
        name: [float(np.max(np.abs(e[(t >= a) & (t < b)]))) for _, a, b in windows]
        for name, e in errs.items()
    }


def table_6_1(per_test: Mapping[str, list[list[float]]]) -> pd.DataFrame:
    """Max, mean and σ over the tests of the per-segment maxima (µm), beside the thesis's."""
    rows = []
    for name in ("e_TOL", "e_TCL", "e_OCL"):
        if name not in per_test:
            continue
        m = np.asarray(per_test[name]) * 1e6  # tests × segments
        pub = THESIS_TABLE_6_1[name]
        for stat, values, published in (
            ("max", m.max(axis=0), pub[0]),
            ("mean", m.mean(axis=0), pub[1]),
            ("σ", m.std(axis=0, ddof=1) if len(m) > 1 else np.full(m.shape[1], np.nan), pub[2]),
        ):
            row = {"error": name, "statistic": stat, "tests": len(m)}
            row |= {f"{seg} [µm]": float(v) for seg, v in zip(SEGMENTS, values)}
            row |= {f"thesis {seg} [µm]": p for seg, p in zip(SEGMENTS, published)}
            rows.append(row)
    return pd.DataFrame(rows)


def p1_summary(t61: pd.DataFrame, stroke: float) -> pd.DataFrame:
    """The thesis's P1 summary (Section 6.3): at the segment with the largest mean open-loop error,
    the mean ε_TOL, ε_TCL, ε_OCL in µm and % of the P1 stroke, and how much closing the loop
    improves on the open loop (1 − ε_TCL/ε_TOL)."""
    mean = t61[t61["statistic"] == "mean"].set_index("error")
    columns = [f"{seg} [µm]" for seg in SEGMENTS]
    worst = max(columns, key=lambda c: mean.loc["e_TOL", c])
    rows = [
        {
            "quantity": f"mean {name}, % of stroke",
            "segment": worst[0],
            "value": 100 * mean.loc[name, worst] * 1e-6 / stroke,
            "mean [µm]": mean.loc[name, worst],
        }
        for name in ("e_TOL", "e_TCL", "e_OCL")
        if name in mean.index
    ]
    if {"e_TOL", "e_TCL"} <= set(mean.index):
        rows.append(
            {
                "quantity": "improvement of closed over open loop [%]",
                "segment": worst[0],
                "value": 100 * (1 - mean.loc["e_TCL", worst] / mean.loc["e_TOL", worst]),
            }
        )
    return pd.DataFrame(rows).assign(**{"stroke [µm]": stroke * 1e6})


def settled_after(warmup: float, omega_c: float) -> float:
    """When Table 6.2's statistics start [s]: after the warm-up and the loop's settling,
    SETTLE_TIME_CONSTANTS/ω_C."""
    return float(warmup) + SETTLE_TIME_CONSTANTS / omega_c


def p2_rows(
    profile: str, run: Mapping[str, np.ndarray], protocol: Mapping, closed: bool, omega_c: float
) -> list[dict]:
    """Table 6.2's rows of a run of the P2 ``profile`` ("P2a" …): its errors after
    :func:`settled_after`."""
    errs = errors(run["x_ref"], run["x_laser"], run["x_hat"] if closed else None, closed)
    after = settled_after(protocol.get("warmup", 0.0), omega_c)
    return profile_errors(profile, run["t"], errs, float(np.ptp(run["x_ref"])), after)


def profile_errors(
    profile: str, t: np.ndarray, errs: Mapping[str, np.ndarray], stroke: float, after: float
) -> list[dict]:
    """Table 6.2 rows of one profile: max |ε| [µm] and % of stroke after ``after`` seconds."""
    rows = []
    for name, e in sorted(errs.items()):
        m = float(np.max(np.abs(e[t >= after])))
        pub = THESIS_TABLE_6_2.get(profile, {}).get(name, (np.nan, np.nan))
        rows.append(
            {
                "profile": profile,
                "error": name,
                "max [µm]": m * 1e6,
                "% of stroke": 100 * m / stroke,
                "thesis [µm]": pub[0],
                "thesis [%]": pub[1],
            }
        )
    return rows


def p3_summary(
    t: np.ndarray,
    open_run: Mapping[str, np.ndarray],
    closed_run: Mapping[str, np.ndarray],
    hold_start: float,
    settle: float = 1.0,
) -> pd.DataFrame:
    """P3: the HPO error during the hold (thesis 0.53 µm) and the creep open vs closed loop."""
    hold = t >= hold_start + settle

    def drift(x):
        return float(x[hold][-1] - x[hold][0]) * 1e6

    return pd.DataFrame(
        [
            {
                "quantity": "max HPO error during the hold (closed loop)",
                "value [µm]": float(
                    np.max(np.abs(closed_run["x_laser"][hold] - closed_run["x_hat"][hold]))
                )
                * 1e6,
                "thesis [µm]": 0.53,
            },
            {
                "quantity": "creep over the hold, open loop",
                "value [µm]": drift(open_run["x_laser"]),
                "thesis [µm]": "< 1",
            },
            {
                "quantity": "creep over the hold, closed loop",
                "value [µm]": drift(closed_run["x_laser"]),
                "thesis [µm]": np.nan,
            },
        ]
    )


#: file names of the figures :func:`figures_ch6` builds, in its order
FIGURES = figure_names.CH6


def figures_ch6(
    runs: Mapping[str, Mapping[str, np.ndarray]],
    protocols: Mapping[str, Mapping],
    profiles: Mapping[str, tuple[str, str]],
) -> dict:
    """Figures 6.2–6.8 from the runs' 4 kHz series ({experiment: {t, x_ref, x_laser, x_hat?, U}})
    of ``profiles`` ({"P1" …: (open-loop run, closed-loop run)}) and their protocols; a figure
    whose runs are missing is left out. P1's figures show the first two of the recording's tests
    (:func:`p1_window`): fifty would hide the minor loops."""
    from selfsense.chapters import figures

    def pair(profile):
        names = profiles.get(profile, (None, None))
        return tuple(runs.get(n) for n in names)

    built = []
    p1o, p1c = pair("P1")
    p1 = p1o is not None and p1c is not None
    if p1:
        shown = p1c["t"] < p1_window(protocols[profiles["P1"][1]])
        p1o, p1c = ({k: None if v is None else v[shown] for k, v in r.items()} for r in (p1o, p1c))
    built.append(
        figures.time_traces(
            p1c["t"],
            [
                (p1c["x_ref"] * 1e6, "x_R [µm]"),
                (p1c["x_laser"] * 1e6, "x closed loop [µm]"),
                (p1o["x_laser"] * 1e6, "x open loop [µm]"),
            ],
            "P1: steps with minor loops (segments a–h), first two tests",
        )
        if p1
        else None
    )
    built.append(
        figures.time_traces(
            p1c["t"],
            [
                ((p1o["x_ref"] - p1o["x_laser"]) * 1e6, "ε_TOL [µm]"),
                ((p1c["x_ref"] - p1c["x_laser"]) * 1e6, "ε_TCL [µm]"),
                ((p1c["x_laser"] - p1c["x_hat"]) * 1e6, "ε_OCL [µm]"),
            ],
            "P1 errors, open and closed loop, first two tests",
        )
        if p1
        else None
    )
    for p in ("P2a", "P2b", "P2c", "P2d"):
        o, c = pair(p)
        built.append(
            None
            if o is None or c is None
            else figures.time_traces(
                c["t"],
                [
                    (c["x_ref"] * 1e6, "x_R [µm]"),
                    (c["x_laser"] * 1e6, "x closed [µm]"),
                    (o["x_laser"] * 1e6, "x open [µm]"),
                    ((c["x_ref"] - c["x_laser"]) * 1e6, "ε_TCL [µm]"),
                ],
                f"{p.upper()}: tracking open and closed loop",
            )
        )
    o, c = pair("P3")
    built.append(
        None
        if o is None or c is None
        else figures.time_traces(
            c["t"],
            [
                (o["U"], "U open loop [V]"),
                (c["U"], "U closed loop [V]"),
                (o["x_laser"] * 1e6, "x open [µm]"),
                (c["x_laser"] * 1e6, "x closed [µm]"),
            ],
            "P3: 50 Hz transient then DC; voltage open vs closed loop",
        )
    )
    return {name: fig for name, fig in zip(FIGURES, built) if fig is not None}
