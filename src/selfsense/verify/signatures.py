"""The calibration signatures measured on short runs of the twin (scripts/calibrate_twin.py).

Each run is an experiment of a campaign's catalogue (the smoke campaign's by default: seconds,
not the thesis's minutes), written by :func:`simulate_capture` into a scratch folder and analysed
with the functions the pipeline's rules call, into tables shaped as the pipeline's. The
calibration targets' locators then read them as they read a campaign's tables
(:func:`selfsense.scorecard.calibration.calibration_table`), so a search and rule twin_calibration
judge one signature by one definition. Runs and what they give (docs/twin.md, "Calibration"):

- the 10 Hz series of Chapter 3 (role ch3.series_10hz, 100 V at 10 Hz): the ripple series of
  rule extract_ripple → the loop widths and phases of rule ch3_hysteresis (ch3/hysteresis.csv,
  ch3/phases.csv; Figs 3.4, 3.10–3.14);
- the set of Chapter 4 the identified model is held to (role identify.recovery_drive): its Case 2
  identification → Table 4.3's U_Pmax (ch4/table_4_3.csv; one set where the campaign averages
  over 10–100 Hz);
- the 0.1 Hz sine of Chapter 5 (role observer.sine): the laser's max − min after the warm-up, as
  the observer stage measures the stroke of Table 5.4 (ch5/table_5_4.csv);
- profile P2a in open loop (role control.p2a_open): P2a's feedforward error ε_TOL in % of stroke
  (ch6/table_6_2.csv, Table 6.2);
- Chapter 7 by closed form, not a 600 s run: τ = ρcv/(k_T A) (Eq 7.5), and the steady temperature
  T_amb + γ P (Eq 7.4 at s = 0, γ = 1/(k_T A), Eq 7.6) with P the heating power (Eq 7.10) of
  the 100 Hz sine of Chapter 5 (role observer.sine), seconds of the 100 Hz heating run's drive
  (100 V at 100 Hz) with the stack near ambient
  (ch7/freq_trend.csv, ch7/table_7_1.csv). The campaign identifies τ and γ from the heating curve
  instead, where C_P's temperature dependence shifts them by a few %
  (docs/twin.md, "Thermal parameters").
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from functools import cache
from pathlib import Path

import numpy as np
import pandas as pd

from selfsense.chapters import ch3, ch4, ch5, ch6, ch7
from selfsense.io import roles
from selfsense.io.capture import open_capture
from selfsense.io.manifest import Experiment
from selfsense.methods.drive import drive_from_protocol
from selfsense.methods.electromech import Geometry
from selfsense.methods.ripple import impedance_series, plan_from_capture
from selfsense.methods.thermal import ThermalModel, ThermalProperties
from selfsense.twin.bench import DaqPlan, simulate_capture
from selfsense.twin.params import TwinParams

#: the short runs, by what they are: {key: (role, nominal drive frequency [Hz] within a role of
#: several runs, or None)}
RUNS = {
    "ch3 10 Hz": ("ch3.series_10hz", None),
    "ch4 set": ("identify.recovery_drive", None),
    "ch5 0.1 Hz": ("observer.sine", 0.1),
    "ch5 100 Hz": ("observer.sine", 100.0),
    "P2a open": ("control.p2a_open", None),
}
#: the tables (relative to results/<dataset>/) the short runs give, each with the runs it needs
TABLES = {
    "ch3/hysteresis.csv": ("ch3 10 Hz",),
    "ch3/phases.csv": ("ch3 10 Hz",),
    "ch4/table_4_3.csv": ("ch4 set",),
    "ch5/table_5_4.csv": ("ch5 0.1 Hz",),
    "ch6/table_6_2.csv": ("P2a open",),
    "ch7/freq_trend.csv": ("ch4 set", "ch5 100 Hz"),
    "ch7/table_7_1.csv": (),
}
#: the companions of the ripple series, as rule extract_ripple writes them
COMPANIONS = ("U", "x_laser", "I")


@dataclass(frozen=True)
class ShortRuns:
    """What the short runs share whatever the twin's parameters: the dataset's DAQ, its campaign's
    catalogue (:func:`selfsense.io.manifest.expand_protocols`), its geometry and moving mass (for
    the Chapter 4 identification), its seed, the config's ripple np and Chapter 6 ω_C, and a scratch
    folder for the captures."""

    daq: DaqPlan
    catalogue: Mapping[str, Experiment]
    geometry: Geometry
    moving_mass: float
    seed: int
    n_periods: int
    omega_c: float
    workdir: Path

    def experiment(self, key: str) -> Experiment:
        """The catalogue's experiment that is the short run ``key`` of :data:`RUNS`."""
        role, hz = RUNS[key]
        if hz is None:
            return self.catalogue[roles.run(self.catalogue, role)]
        return self.catalogue[roles.by_frequency(self.catalogue, role)[hz]]

    def tables(
        self, params: TwinParams, wanted: Iterable[str] = tuple(TABLES)
    ) -> dict[str, pd.DataFrame]:
        """{table: table} of the ``wanted`` tables of :data:`TABLES`, from runs of the twin with
        ``params``; only the runs they need are made, each once."""
        wanted = list(wanted)
        unknown = [t for t in wanted if t not in TABLES]
        if unknown:
            raise ValueError(f"no short run gives {unknown[0]} (they give {', '.join(TABLES)})")

        @cache
        def capture(key):
            return _capture(params, self.daq, self.experiment(key), self.seed, self.workdir)

        @cache
        def steady():
            return ch3.steady(
                _ripple_series(capture("ch3 10 Hz"), self.n_periods), 0.1
            )  # ch3_hysteresis's skip_s

        @cache
        def identified():
            return _identify(
                capture("ch4 set"), self.n_periods, params, self.moving_mass, self.geometry
            )

        thermal = ThermalModel.from_k_T(
            params.thermal.k_T,
            ThermalProperties(
                params.thermal.rho, params.thermal.c, params.thermal.volume, params.thermal.area
            ),
        )

        def steady_temperature():
            heating = _heating_power(
                capture("ch5 100 Hz"), self.n_periods, identified().case2.k_over_alpha
            )
            f = self.experiment("ch5 100 Hz").protocol["segments"][0]["frequency"]
            # the columns of ch7.steady_rise_trends, from the closed form
            return pd.DataFrame(
                {
                    "frequency [Hz]": [f],
                    "steady temperature [°C]": [
                        params.thermal.T_amb + thermal.steady_state_rise(heating)
                    ],
                }
            )

        makers = {
            "ch3/hysteresis.csv": lambda: ch3.hysteresis_table(steady()),
            "ch3/phases.csv": lambda: ch3.phase_table(steady(), 10.0),
            "ch4/table_4_3.csv": lambda: ch4.table_4_3(
                {self.experiment("ch4 set").name: identified()}, self.geometry
            ),
            "ch5/table_5_4.csv": lambda: ch5.table_5_4(
                {
                    0.1: {
                        "max error [µm]": np.nan,
                        "error [% of stroke]": np.nan,
                        "stroke [µm]": _stroke(capture("ch5 0.1 Hz")) * 1e6,
                    }
                }
            ),
            "ch6/table_6_2.csv": lambda: _feedforward_errors(
                capture("P2a open"), self.experiment("P2a open"), self.omega_c
            ),
            "ch7/freq_trend.csv": steady_temperature,
            # the columns of ch7.table_7_1, from the closed form
            "ch7/table_7_1.csv": lambda: pd.DataFrame(
                {"parameter": ["tau [s]"], "reproduced": [thermal.tau]}
            ),
        }
        return {t: makers[t]() for t in wanted}


def _capture(
    params: TwinParams, daq: DaqPlan, experiment: Experiment, seed: int, workdir: Path
) -> Path:
    """One experiment's capture, written uncompressed (a scratch file, read once)."""
    path = workdir / f"{experiment.name}.nc"
    warmup = float(experiment.protocol.get("warmup", 0.0))
    attrs = {
        "dataset": "calibration search",
        "protocol": experiment.chapter,
        "campaign": "calibration",
        "description": "a short run of a calibration search (scripts/calibrate_twin.py)",
        "warmup_s": warmup,
        "control": experiment.control,
    }
    simulate_capture(
        path,
        params,
        daq,
        drive_from_protocol(experiment.protocol),
        attrs,
        seed,
        experiment.name,
        load_stiffness=experiment.load_stiffness,
        compression=None,
    )
    return path


def _ripple_series(path: Path, n_periods: int) -> dict[str, np.ndarray]:
    """The capture's ripple series, as rule extract_ripple writes it (whole: a short run)."""
    with open_capture(path, require=("Ur", "Ir") + COMPANIONS) as cap:
        parts = list(
            impedance_series(
                cap.iter_chunks(("Ur", "Ir") + COMPANIONS),
                plan_from_capture(cap, n_periods),
                cap.fs,
                COMPANIONS,
            )
        )
    return {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}


def _identify(
    path: Path, n_periods: int, params: TwinParams, moving_mass: float, geometry: Geometry
):
    """Case 2 of one Chapter 4 set, as rule identify finds it (Case 1's static stiffness is the
    twin's k: Table 4.3 uses Case 2 only)."""
    _, fits = ch4.identify_sets(
        {path.stem: _ripple_series(path, n_periods)}, params.stack.k, moving_mass, geometry
    )
    return fits[path.stem]


def _stroke(path: Path) -> float:
    """Max − min of the laser after the warm-up, zeroed at the start, as ch5.run_observer measures
    it [m]."""
    with open_capture(path, require=("x_laser",)) as cap:
        settle = float(cap.attribute("warmup_s"))
        x = np.concatenate([d["x_laser"] for _, d in cap.iter_chunks(("x_laser",))])
        t = np.arange(len(x)) / cap.fs
    after = x[t >= settle] - x[0]
    return float(np.max(after) - np.min(after))


def _feedforward_errors(path: Path, experiment: Experiment, omega_c: float) -> pd.DataFrame:
    """Table 6.2's rows of P2a's open-loop run, as rule ch6_results makes them."""
    series = ch6.load_run(path, experiment.protocol)
    return pd.DataFrame(ch6.p2_rows("P2a", series, experiment.protocol, False, omega_c))


def _heating_power(path: Path, n_periods: int, k_over_alpha: float) -> float:
    """The mean loss power while the drive heats (Eq 7.10), as rule thermal_extract and the
    identification compute it [W]."""
    with open_capture(path, require=("U", "I", "x_laser", "Ur", "Ir")) as cap:
        power = [
            p["P_PS"]
            for p, _, _ in ch7.extract(
                cap.iter_chunks(("U", "I", "x_laser", "Ur", "Ir")),
                cap.fs,
                plan_from_capture(cap, n_periods),
                k_over_alpha,
                0.1,
                200,
            )
        ]
    return ch7.heating_power(np.concatenate(power))
