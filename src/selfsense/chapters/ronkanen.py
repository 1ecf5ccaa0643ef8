"""Ronkanen, Kallio, Koivo 2002: Tables 1–2, Figures 2–11 and the positioning results.

Captures in (as :class:`Record`), tables (DataFrames) and figures out; the maths is in
:mod:`selfsense.methods.powerloss`. Units are SI inside; nA, GΩ, µm and µAs appear only in column
names and axis labels.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from selfsense.chapters import figure_names, figures
from selfsense.io.capture import open_capture
from selfsense.methods import powerloss as pl

plt = figures.plt
#: the DAQ channels this chapter reads
CHANNELS = ("U", "I", "i_cmd", "x_disp")
UM, NA, GOHM = 1e6, 1e9, 1e-9
#: plotted traces are thinned to at most this many points (long runs would make huge PDFs)
MAX_POINTS = 20000
#: reversals smaller than this share of a record's range are not branch ends
MIN_SWING = 0.05
#: the positioning experiments (Section 7), each run under both controls:
#: "<kind>_<control>" names them
KINDS = ("decay", "repeat", "drift")
CONTROLS = ("current", "voltage")
PAIRS = tuple(f"{k}_{c}" for k in KINDS for c in CONTROLS)
#: Figs 3–5: the ±300 nA ramps compensated for a too large, a too small and the paper's ideal X
RAMP_FIGURES = {3: "too large", 4: "too small", 5: "the paper's ideal"}
#: {paper figure: file name} of the figures :func:`figures_paper` builds
FIGURES = figure_names.RONKANEN


@dataclass(frozen=True)
class Record:
    """One capture of the bench: channels in SI units and the operator's settings."""

    name: str
    t: np.ndarray
    U: np.ndarray  # amplifier output [V]
    I: np.ndarray  # current meter [A]
    i_cmd: np.ndarray  # charging-current command i_c [A] (0 in voltage control)
    x: np.ndarray  # displacement sensor [m]
    quantity: str  # "current" or "voltage"
    compensation: str  # none | impedance | model_10
    X_trial: float  # trial impedance of Section 5 [Ω] (inf unless compensation == impedance)

    @classmethod
    def from_channels(
        cls, name: str, data: Mapping[str, np.ndarray], attrs: Mapping[str, object], fs: float
    ) -> Record:
        return cls(
            name,
            np.arange(len(data["U"])) / fs,
            data["U"],
            data["I"],
            data["i_cmd"],
            data["x_disp"],
            str(attrs["drive_quantity"]),
            str(attrs["compensation"]),
            float(attrs["compensation_X"]),
        )

    @property
    def charge_command(self) -> np.ndarray:
        """∫ i_c dt [C], the 'integral of control current' of Figs 3–5."""
        return pl.displacement_from_current(self.t, self.i_cmd, 1.0)

    def required(self, a_cmd: float) -> np.ndarray:
        """The required displacement.

        Current control: a_cmd·∫i_c (Eq 2) with the bench's calibrated displacement per
        commanded charge. Open-loop voltage control: g·U with g the least-squares gain of this
        record, the best any linear voltage model could do.
        """
        if self.quantity == "current":
            return a_cmd * self.charge_command
        return pl.linear_gain(self.U, self.x) * self.U


def read_records(paths: Iterable[str | Path]) -> dict[str, Record]:
    """{experiment: Record} of captures, opened and validated by :mod:`selfsense.io.capture`.

    The bench's records are short (100 Hz), so each is read whole.
    """
    records = {}
    for path in paths:
        with open_capture(path, require=CHANNELS) as cap:
            records[Path(path).stem] = Record.from_channels(
                Path(path).stem, cap.read(CHANNELS), cap.attrs, cap.fs
            )
    return records


# ---------------------------------------------------------------------------------------------
# Section 4–5: R from the static hold, X from the ramps (Table 1), models (Table 2)
# ---------------------------------------------------------------------------------------------
def by_kind(
    records: Mapping[str, Record], captures: Mapping[str, str | Path]
) -> dict[str, dict[str, Record]]:
    """{kind: {control: Record}} of the positioning runs; ``captures``:
    {"<kind>_<control>": path}."""
    return {k: {c: records[Path(captures[f"{k}_{c}"]).stem] for c in CONTROLS} for k in KINDS}


def load_identified(path: str | Path, key: str) -> float:
    """One of the identified constants :func:`identify` returns (e.g. R [Ω], a_cmd [m/C]), as
    written to CSV."""
    return float(pd.read_csv(path).set_index("key").loc[key, "value"])


def ramp_row(rec: Record, velocity_window: float) -> dict[str, object]:
    """X, a and the charging current of one ramp record (Section 5); the velocity spread is the
    paper's own test of a trial X (Figs 3–5)."""
    est = pl.impedance_from_ramp(
        rec.t, rec.x, rec.I, rec.U, segments=pl.constant_stretches(rec.i_cmd)
    )
    charging = np.mean(np.abs(pl.charging_current(rec.I, rec.U, est.impedance)))
    # the command channel is 16-bit: its level to 0.1 nA
    return {
        "experiment": rec.name,
        "current command [nA]": round(float(np.max(np.abs(rec.i_cmd))) * NA, 1),
        "trial impedance [GOhm]": rec.X_trial * GOHM,
        "identified X [GOhm]": est.impedance * GOHM,
        "charging current [nA]": charging * NA,
        "a [m/C]": est.gain,
        "velocity spread [%]": pl.velocity_spread(rec.t, rec.x, rec.i_cmd, velocity_window),
    }


def table_1(ramps: pd.DataFrame) -> pd.DataFrame:
    """Table 1: the loss impedance per drive-current level (mean over that level's ramps)."""
    paper = {round(current * NA): x for current, x in pl.PAPER_TABLE_1.items()}
    rows = []
    for level, group in ramps.groupby("current command [nA]"):
        rows.append(
            {
                "current [nA]": level,
                "ramps": len(group),
                "charging current [nA]": group["charging current [nA]"].mean(),
                "identified X [GOhm]": group["identified X [GOhm]"].mean(),
                "paper X [GOhm]": paper.get(round(level), np.nan) * GOHM,
            }
        )
    return pd.DataFrame(rows)


def identify(
    hold: Record, ramps: list[Record], hold_start: float, velocity_window: float
) -> tuple[pd.DataFrame, pd.DataFrame, pd.DataFrame]:
    """Ramps table, Table 1 and the identified constants (R, a, a_cmd) from the captures.

    R comes from the second half of the hold (the meter and the creep have settled) with the
    residual drift removed through a from the ramps
    (:func:`selfsense.methods.powerloss.hold_from_record`). a_cmd, the displacement per *commanded*
    charge that the 'displacement to current' block needs (Eq 3), is calibrated on the
    best-compensated ramp — the one whose trial impedance is closest to the X identified from it —
    so it carries the current loop's own gain.
    """
    ramp_table = pd.DataFrame([ramp_row(r, velocity_window) for r in ramps])
    a = float(ramp_table["a [m/C]"].median())
    window = hold.t >= hold_start + 0.5 * (hold.t[-1] - hold_start)
    est = pl.hold_from_record(hold.t[window], hold.U[window], hold.I[window], hold.x[window], a)
    mismatch = np.abs(
        np.log(ramp_table["trial impedance [GOhm]"] / ramp_table["identified X [GOhm]"])
    )
    ideal = ramps[int(mismatch.idxmin())]
    a_cmd = pl.linear_gain(ideal.charge_command, ideal.x - ideal.x[0])
    identified = pd.DataFrame(
        [
            {
                "key": "R",
                "value": est.R,
                "unit": "Ohm",
                "paper": pl.PAPER_HOLD_RESISTANCE,
                "note": "hold: mean V over the leaking part of the mean current (Section 4)",
            },
            {
                "key": "R_ohm",
                "value": est.R_ohm,
                "unit": "Ohm",
                "paper": pl.PAPER_HOLD_RESISTANCE,
                "note": "hold: plain V/i_hold, biased when the hold does not stand still",
            },
            {
                "key": "V_hold",
                "value": est.voltage,
                "unit": "V",
                "paper": pl.PAPER_HOLD_VOLTAGE,
                "note": "hold voltage",
            },
            {
                "key": "I_hold",
                "value": est.current,
                "unit": "A",
                "paper": pl.PAPER_HOLD_CURRENT,
                "note": "hold current",
            },
            {
                "key": "hold_velocity",
                "value": est.velocity,
                "unit": "m/s",
                "paper": 0.0,
                "note": "residual velocity during the hold",
            },
            {
                "key": "a",
                "value": a,
                "unit": "m/C",
                "paper": np.nan,
                "note": "Eq 2, median over the ramps",
            },
            {
                "key": "a_cmd",
                "value": a_cmd,
                "unit": "m/C",
                "paper": 5e-6 / 300e-9,
                "note": f"per commanded charge, from {ideal.name} (paper: 5 um/s at 300 nA)",
            },
        ]
    )
    return ramp_table, table_1(ramp_table), identified


def table_2_both(table1: pd.DataFrame, R: float) -> pd.DataFrame:
    """Table 2 twice: fitted to the paper's Table 1 and to the impedances identified here.

    Both fits hold X(0) at their own R (the paper's 21 GΩ; the hold's R here) and use one point
    per current level, as the paper does.
    """
    currents = np.concatenate([[0.0], table1["charging current [nA]"].to_numpy() / NA])
    impedances = np.concatenate([[R], table1["identified X [GOhm]"].to_numpy() / GOHM])
    parts = [
        pl.table_2().assign(source="paper Table 1", R_GOhm=pl.PAPER_HOLD_RESISTANCE * GOHM),
        pl.table_2(currents, impedances, R).assign(source="twin captures", R_GOhm=R * GOHM),
    ]
    out = pd.concat(parts, ignore_index=True).rename(columns={"R_GOhm": "R [GOhm]"})
    out["paper c"] = np.where(out["equation"] == "(10)", pl.PAPER_C_EQ12, np.nan)
    return out[
        [
            "source",
            "model",
            "equation",
            "formula",
            "R [GOhm]",
            "c",
            "c_unit",
            "paper c",
            "SSE [GOhm^2]",
            "paper SSE [GOhm^2]",
            "best",
        ]
    ]


# ---------------------------------------------------------------------------------------------
# Section 7: decaying ramp, hysteresis, repeatability and drift
# ---------------------------------------------------------------------------------------------
PAPER_RESULTS = {  # Section 7–8: (current control, open-loop voltage control)
    "hysteresis [%]": (1.5, 27.0),
    "drift over the hold [%]": (1.5, 15.0),
    "repeatability drift [%]": (2.0, np.nan),
    "peak-to-peak change [%]": (0.5, np.nan),
    "decaying-ramp max error [um]": (10.0, np.nan),
}


def cycles(rec: Record, a_cmd: float) -> pd.DataFrame:
    """Per-cycle peaks of a repeated ramp (Fig 10)."""
    required = rec.required(a_cmd)
    return pl.repeatability(rec.t, required, rec.x, MIN_SWING * np.ptp(required))


def performance(
    decay: Mapping[str, Record],
    repeat: Mapping[str, Record],
    drift: Mapping[str, Record],
    a_cmd: float,
    drift_start: float,
    drift_duration: float,
) -> pd.DataFrame:
    """The four results of Section 7 for current control and open-loop voltage control.

    Each mapping is {"current": record, "voltage": record}. Hysteresis and max error come from
    the decaying ramp (Figs 8–9), repeatability from the repeated ramps (Fig 10), drift from the
    hold after a ramp (Fig 11), each beside the paper's number.
    """
    rows = []
    for control, column in (("current", 0), ("voltage", 1)):
        rec = decay[control]
        required = rec.required(a_cmd)
        swing = MIN_SWING * np.ptp(required)
        per_cycle = cycles(repeat[control], a_cmd)
        first, last = per_cycle.iloc[0], per_cycle.iloc[-1]
        held = drift[control]
        values = {
            "hysteresis [%]": pl.branch_hysteresis_percent(required, rec.x, swing),
            "drift over the hold [%]": pl.drift_percent(
                held.t, held.x, drift_start, drift_duration
            ),
            "repeatability drift [%]": 100
            * (last["midpoint [m]"] - first["midpoint [m]"])
            / first["peak-to-peak [m]"],
            "peak-to-peak change [%]": 100
            * (last["peak-to-peak [m]"] / first["peak-to-peak [m]"] - 1),
            "decaying-ramp max error [um]": pl.max_error(required, rec.x) * UM,
        }
        hold_s = min(drift_duration, held.t[-1] - drift_start)
        notes = {
            "drift over the hold [%]": f"{hold_s:.0f} s hold",
            "repeatability drift [%]": f"{len(per_cycle)} cycles",
            "peak-to-peak change [%]": f"{len(per_cycle)} cycles",
        }
        for measure, value in values.items():
            rows.append(
                {
                    "measure": measure,
                    "control": control,
                    "value": float(value),
                    "paper": PAPER_RESULTS[measure][column],
                    "note": notes.get(measure, ""),
                }
            )
    return pd.DataFrame(rows)


# ---------------------------------------------------------------------------------------------
# Parameter recovery (twin validation; reads the twin's truth, which analyses never do)
# ---------------------------------------------------------------------------------------------
#: relative tolerances [%] of the recovery and why
TOLERANCES = {
    "R": (
        3.0,
        "hold current read through the ADC's 76 pA step (±0.6 %) and the sensor drift "
        "left in the residual-velocity correction",
    ),
    "a": (1.0, "charge balance over whole ramps; sensor noise 0.2 µm against 250 µm strokes"),
    "X": (3.0, "one constant X per ramp while i_C wanders by the compensation error"),
    "c": (
        2.0,
        "c ≈ √((R/X)² − 1)/i ≈ R/(X i): R's error (the ADC step, ±0.6 %) and that of the "
        "ramps' mean X at each current (≈ 1 %) add; the scorecard's twin-input rule",
    ),
}


def recovery(
    identified: pd.DataFrame, table1: pd.DataFrame, table2: pd.DataFrame, truth: Mapping[str, float]
) -> pd.DataFrame:
    """Identified R, a, X per level and c against the twin's true parameters."""
    value = identified.set_index("key")["value"]
    R, c = float(truth["actuator_R"]), float(truth["actuator_c"])
    twin = table2[(table2["source"] == "twin captures") & (table2["equation"] == "(10)")].iloc[0]
    rows = [
        ("R", "R [Ohm]", value["R"], R),
        ("a", "a [m/C]", value["a"], float(truth["actuator_a"])),
        ("c", "c of model (10) [1/A]", float(twin["c"]), c),
    ]
    for _, level in table1.iterrows():
        i_C = level["charging current [nA]"] / NA
        rows.append(
            (
                "X",
                f"X at {level['current [nA]']:g} nA [Ohm]",
                level["identified X [GOhm]"] / GOHM,
                float(pl.get_impedance_model(10)(i_C, R, c)),
            )
        )
    out = []
    for kind, name, found, true in rows:
        tol, why = TOLERANCES[kind]
        error = 100 * (found / true - 1)
        out.append(
            {
                "parameter": name,
                "identified": found,
                "truth": true,
                "error [%]": error,
                "tolerance [%]": tol,
                "within": abs(error) <= tol,
                "why this tolerance": why,
            }
        )
    return pd.DataFrame(out)


# ---------------------------------------------------------------------------------------------
# Figures 2–11
# ---------------------------------------------------------------------------------------------
def figures_paper(
    records: Mapping[str, Record],
    hold: str | Path,
    ramps: Iterable[str | Path],
    captures: Mapping[str, str | Path],
    table1: pd.DataFrame,
    table2: pd.DataFrame,
    a_cmd: float,
    drift_start: float,
    velocity_window: float,
) -> dict[str, object]:
    """Figures 2–11 by file name (:data:`FIGURES`) from the ``records`` of :func:`read_records`,
    each named by its capture: the static ``hold``, the ±300 nA ``ramps`` compensated for too
    large, too small and the ideal X (Figs 3, 4, 5–6, the order of :data:`RAMP_FIGURES`) and the
    positioning runs ``captures`` ({"<decay|repeat|drift>_<current|voltage>": path},
    :func:`by_kind`), with Tables 1 and 2, the identified a_cmd [m/C], the drift hold's start [s]
    and the window [s] of the ramps' velocity."""
    pairs = by_kind(records, captures)
    velocity = dict(zip(RAMP_FIGURES, (records[Path(r).stem] for r in ramps)))
    built = {2: figure_2(records[Path(hold).stem])}
    for n, rec in velocity.items():
        built[n] = velocity_figure(
            rec,
            velocity_window,
            f"Ramp velocity, compensation for "
            f"{rec.X_trial / 1e9:g} GΩ ({RAMP_FIGURES[n]}) (Fig {n})",
        )
    built |= {
        6: figure_6(velocity[5]),
        7: figure_7(table1, table2),
        8: figure_8(pairs["decay"], a_cmd),
        9: figure_9(pairs["decay"], a_cmd),
        10: figure_10(pairs["repeat"], a_cmd),
        11: figure_11(pairs["drift"], drift_start),
    }
    return {FIGURES[n]: fig for n, fig in built.items()}


def _thin(*arrays: np.ndarray):
    step = max(1, len(arrays[0]) // MAX_POINTS)
    return tuple(a[::step] for a in arrays)


def figure_2(hold: Record):
    t, x, i, u = _thin(hold.t, hold.x, hold.I, hold.U)
    return figures.time_traces(
        t,
        [(x * UM, "displacement [µm]"), (i * NA, "current [nA]"), (u, "voltage [V]")],
        "Current consumption in static operation (Fig 2)",
    )


def velocity_figure(rec: Record, window: float, title: str):
    """Figs 3–5: ramp velocity against the integral of the control current."""
    velocity = pl.ramp_velocity(rec.t, rec.x, window)
    q, v = _thin(rec.charge_command, velocity)
    fig, ax = plt.subplots(figsize=(6.4, 4.2), constrained_layout=True)
    ax.plot(q * 1e6, v * UM, lw=0.8)
    ax.set(xlabel="integral of control current [µAs]", ylabel="velocity [µm/s]", title=title)
    ax.grid(alpha=0.3)
    return fig


def figure_6(rec: Record):
    t, x = _thin(rec.t, rec.x)
    return figures.time_traces(
        t,
        [(x * UM, "displacement [µm]")],
        f"Ramp curve, ±{np.max(np.abs(rec.i_cmd)) * NA:.0f} nA, "
        f"compensation for {rec.X_trial * GOHM:g} GΩ (Fig 6)",
    )


def figure_7(table1: pd.DataFrame, table2: pd.DataFrame):
    """Fig 7: the five impedance models fitted to the paper's Table 1 and to the twin's."""
    fig, axes = plt.subplots(1, 2, figsize=(10, 4.2), sharey=True, constrained_layout=True)
    i = np.linspace(-0.4e-6, 0.4e-6, 801)
    points = {
        "paper Table 1": pl.paper_fit_points(),
        "twin captures": (
            np.concatenate([[0.0], table1["charging current [nA]"] / NA]),
            np.concatenate(
                [
                    [table2.loc[table2["source"] == "twin captures", "R [GOhm]"].iloc[0] / GOHM],
                    table1["identified X [GOhm]"] / GOHM,
                ]
            ),
        ),
    }
    for ax, (source, (pi, px)) in zip(axes, points.items()):
        fits = table2[table2["source"] == source]
        for _, row in fits.iterrows():
            model = pl.get_impedance_model(row["model"])
            ax.plot(
                i * 1e6,
                model(i, row["R [GOhm]"] / GOHM, row["c"]) * GOHM,
                lw=1,
                label=f"{row['equation']} {model.formula}",
            )
        ax.plot(
            np.concatenate([-pi[1:], pi]) * 1e6,
            np.concatenate([px[1:], px]) * GOHM,
            "ko",
            label="data",
        )
        # model (9) as printed has a pole at i = -1/c; show the range of the data, as the paper does
        ax.set(
            xlabel="current [µA]",
            title=f"Impedance models, {source}",
            ylim=(0, 1.25 * px[0] * GOHM),
        )
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("impedance [GΩ]")
    axes[1].legend(fontsize=7)
    return fig


def _by_control(records: Mapping[str, Record], a_cmd: float, title: str, minutes: bool = False):
    fig, axes = plt.subplots(
        len(records), 1, figsize=(6.4, 6.6), sharex=True, constrained_layout=True
    )
    scale = 1 / 60 if minutes else 1.0
    for ax, (control, rec) in zip(np.atleast_1d(axes), records.items()):
        required = rec.required(a_cmd)
        t, req, x = _thin(rec.t, required, rec.x)
        ax.plot(t * scale, req * UM, lw=0.8, label="required")
        ax.plot(t * scale, x * UM, lw=0.8, label="measured")
        ax.set(ylabel="displacement [µm]", title=f"{control} control")
        ax.legend(loc="upper right", fontsize=7)
        ax.grid(alpha=0.3)
    np.atleast_1d(axes)[-1].set_xlabel("time [min]" if minutes else "time [s]")
    fig.suptitle(title)
    return fig


def figure_8(decay: Mapping[str, Record], a_cmd: float):
    return _by_control(decay, a_cmd, "Decaying ramp curve (Fig 8)")


def figure_9(decay: Mapping[str, Record], a_cmd: float):
    pairs = {control: _thin(rec.required(a_cmd), rec.x) for control, rec in decay.items()}
    return figures.loop(
        [p[0] * UM for p in pairs.values()],
        [p[1] * UM for p in pairs.values()],
        "required displacement [µm]",
        "displacement [µm]",
        "Hysteresis of the decaying ramp curve (Fig 9)",
        labels=[f"{c} control" for c in pairs],
    )


def figure_10(repeat: Mapping[str, Record], a_cmd: float):
    return _by_control(repeat, a_cmd, "Ramp curve driven repeatedly (Fig 10)", minutes=True)


def figure_11(drift: Mapping[str, Record], drift_start: float):
    fig, ax = plt.subplots(figsize=(6.4, 4.2), constrained_layout=True)
    for control, rec in drift.items():
        t, x = _thin(rec.t, rec.x)
        ax.plot(t, x * UM, lw=0.8, label=f"{control} control")
    ax.axvline(drift_start, color="0.5", ls=":", label="hold starts")
    ax.set(xlabel="time [s]", ylabel="displacement [µm]", title="Drift (Fig 11)")
    ax.legend()
    ax.grid(alpha=0.3)
    return fig
