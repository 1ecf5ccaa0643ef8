"""Digital twin of the Ronkanen 2002 bench: a Tokin piezo bender under current or voltage drive.

Physics (equation numbers are the paper's unless marked "thesis"):

    x = a·Q                                   displacement follows the charge (Eq 2)
    V = Q/C + U_H(Q) + Σ U_c                  terminal voltage: capacitance, hysteresis, creep
    I = i_C + i_l,  i_C = dQ/dt               total current (Eq 4)
    i_l = V/X(i_C),  X = R/√((c·i_C)² + 1)    loss impedance across the terminals (Eq 5, 10, 13)

U_H is the Maxwell resistive-capacitive operator on Q (thesis Eq 1.11–1.12, :mod:`.maxwell`, shared
with the stack's twin) and U_c are Voigt
relaxation elements charged by i_C: under a voltage they let Q creep, under a current they only
change V. The loss impedance is model (10) as the twin's physics, a function of the charging
current i_C (the rate of motion), so at rest it is the leakage resistance R (Section 4).

Bench (Fig 1): a voltage amplifier of gain G drives the bender; in current mode a discrete PID
(:class:`selfsense.methods.powerloss.CurrentPID`) sets the amplifier input so that the current meter
reads the setpoint i_t, which the feedforward block makes from the charging-current command i_c
(Eq 3) plus the loss current: none, V/X for a trial impedance X (Eq 13), or Eq 15 with the
operator's R and c. V in Eq 13/15 is the PID output times G of the previous sample, as the paper
reads it. In voltage mode the amplifier input follows the drive directly (open loop).
Into the capacitive load the PID's integral gain is a proportional current gain K = C·G·ki, so
the loop settles at K/(1 + K) of its setpoint, and the meter's lag τ shifts the delivered charge
by τ·Δi at every reversal: these, not the loss model, set most of the current-control error.

Discretisation: the amplifier output is held over each sample (zero-order hold), so Q jumps to
its new balance each sample and the charging current is ΔQ·fs; the meter is a first-order lag
driven by that piecewise-constant current (exact), with its resolution and noise; the creep
elements are discretised exactly for the held i_C. The hysteresis makes the voltage balance
nonlinear, so there is no exact linear discretisation: the loop is a numba kernel, and
:func:`run_reference` is the plain-Python version (Brent's method, the library's PID and Eq 15)
that the tests hold it to.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import asdict, dataclass, fields
from pathlib import Path
from typing import Any

import numba
import numpy as np
import pandas as pd
from scipy.optimize import brentq

from selfsense import __version__
from selfsense.io.capture import TWIN_COMPRESSION, CaptureWriter, ScanReport, channel_spec
from selfsense.io.manifest import IDENTIFIED, Experiment, needs_identification
from selfsense.methods import powerloss as pl
from selfsense.methods.drive import Drive, drive_from_protocol
from selfsense.methods.hysteresis import newton_step
from selfsense.twin.bench import DaqPlan, experiment_seed
from selfsense.twin.instruments import SlowProcess
from selfsense.twin.maxwell import (
    MAX_ITERATIONS,
    KernelConstants,
    balanced,
    maxwell,
    maxwell_reference,
    slide_anchors_reference,
    slide_and_sum,
    span,
)
from selfsense.twin.params import CreepParams, HysteresisParams, build_sections

#: kernel output columns, in order
OUTPUTS = ("V", "I", "I_meter", "Q", "U_H", "U_c", "i_t", "i_C", "i_l")
N_OUT = len(OUTPUTS)
#: noiseless states kept in the capture's /truth group
TRUTH_STATES = ("x", "Q", "V", "U_H", "U_c", "I", "i_C", "i_l", "X")
MODES = {"voltage": 0, "current": 1}
COMPENSATIONS = {"none": 0, "impedance": 1, "model_10": 2}


@dataclass(frozen=True)
class ActuatorParams:
    """The bender's electromechanics: C ∥ X(i_C) with displacement a·Q."""

    C: float  # capacitance [F]
    a: float  # displacement per charge (Eq 2) [m/C]
    R: float  # leakage resistance at rest (Section 4) [Ω]
    c: float  # loss-impedance constant of model (10) [1/A]


@dataclass(frozen=True)
class AmplifierParams:
    gain: float  # voltage gain G [V/V]
    u_max: float  # input range ±u_max [V]; the output saturates at ±G·u_max


@dataclass(frozen=True)
class PIDParams:
    """The operator's PID of Fig 1 (parallel form; u in volts at the amplifier input)."""

    kp: float  # [V/A]
    ki: float  # [V/(A s)]
    kd: float  # [V s/A]


@dataclass(frozen=True)
class BenderInstruments:
    meter_tau: float  # current meter's output time constant [s]
    meter_resolution: float  # reading step [A]
    meter_noise: float  # [A rms]
    meter_offset: float  # zero offset left after nulling [A]
    U_noise: float  # DAQ noise on the amplifier-output channel [V rms]
    x_noise: float  # displacement sensor noise [m rms]
    x_drift: float  # displacement sensor slow drift, peak [m]
    x_drift_bandwidth: float  # [Hz]


@dataclass(frozen=True)
class BenderParams:
    actuator: ActuatorParams
    hysteresis: HysteresisParams
    creep: CreepParams
    amplifier: AmplifierParams
    pid: PIDParams
    instruments: BenderInstruments

    @classmethod
    def from_manifest(cls, twin: Mapping[str, Any], where: str = "twin") -> BenderParams:
        return build_sections(cls, twin, where)

    def truth_attrs(self) -> dict[str, float | np.ndarray]:
        """Flat {section_key: value} of every parameter, for the capture's /truth group."""
        out: dict[str, float | np.ndarray] = {}
        for part in fields(self):
            for key, value in asdict(getattr(self, part.name)).items():
                out[f"{part.name}_{key}"] = (
                    np.asarray(value, float) if isinstance(value, tuple) else float(value)
                )
        return out


def identified_compensation(identified: str | Path, table_2: str | Path) -> dict[str, float]:
    """Eq 15's {"R": [Ω], "c": [1/A]} as the pipeline identified them from the captures that need
    no compensation of this kind (the static hold and the fixed-impedance ramps): R from the hold
    (``identified``, results/<dataset>/powerloss/identified.csv, key R) and c of model (10) fitted
    to the ramps' impedances with that R held (``table_2``, source "twin captures", equation (10)).
    """
    values = pd.read_csv(identified).set_index("key")["value"]
    table = pd.read_csv(table_2)
    fit = table[(table["source"] == "twin captures") & (table["equation"] == "(10)")]
    if "R" not in values.index or len(fit) != 1:
        raise ValueError(
            f"{identified}, {table_2}: no identified R (key R) or no single model (10) fit "
            "to the twin's captures (source twin captures, equation (10))"
        )
    return {"R": float(values["R"]), "c": float(fit["c"].iloc[0])}


@dataclass(frozen=True)
class Compensation:
    """The feedforward block of Fig 1: which loss current the controller adds to i_c.

    ``none``: i_t = i_c; ``impedance``: i_t = i_c + V/X (Eq 13, a trial X of Section 5);
    ``model_10``: Eq 15 with the operator's R and c.
    """

    kind: str = "none"
    X: float = math.inf
    R: float = math.inf
    c: float = 0.0

    @classmethod
    def from_protocol(
        cls, entry: Mapping[str, Any] | None, identified: Mapping[str, float] | None = None
    ) -> Compensation:
        """The setting a protocol's ``compensation`` names; ``identified``: the identified
        {"R", "c"} (:func:`identified_compensation`) that ``{R: identified, c: identified}``
        takes."""
        if not entry:
            return cls()
        if "impedance" in entry:
            return cls("impedance", X=float(entry["impedance"]))
        if needs_identification(entry):
            if identified is None:
                raise ValueError(
                    "compensation {R: identified, c: identified} needs the identified R and c "
                    "(results/<dataset>/powerloss/identified.csv, table_2.csv); none was given"
                )
            entry = {k: identified[k] if entry[k] == IDENTIFIED else entry[k] for k in ("R", "c")}
        return cls("model_10", R=float(entry["R"]), c=float(entry["c"]))

    def attrs(self) -> dict[str, object]:
        return {
            "compensation": self.kind,
            "compensation_X": self.X,
            "compensation_R": self.R,
            "compensation_c": self.c,
        }


_SCALARS = (
    "C",
    "R",
    "c",
    "gain",
    "u_max",
    "kp",
    "ki",
    "kd",
    "fs",
    "meter_decay",
    "meter_resolution",
    "meter_offset",
    "comp_kind",
    "comp_X",
    "comp_R",
    "comp_c",
)
#: state layout: Q, V, meter output, last reading, PID integral, previous error, has-previous flag
_HEAD = 7


def kernel_constants(
    p: BenderParams, fs: float, compensation: Compensation = Compensation()
) -> KernelConstants:
    act, ins = p.actuator, p.instruments
    values = dict(
        C=act.C,
        R=act.R,
        c=act.c,
        gain=p.amplifier.gain,
        u_max=p.amplifier.u_max,
        kp=p.pid.kp,
        ki=p.pid.ki,
        kd=p.pid.kd,
        fs=fs,
        meter_decay=math.exp(-1.0 / (fs * ins.meter_tau)),
        meter_resolution=ins.meter_resolution,
        meter_offset=ins.meter_offset,
        comp_kind=COMPENSATIONS[compensation.kind],
        comp_X=compensation.X,
        comp_R=compensation.R,
        comp_c=compensation.c,
    )
    return KernelConstants.build(
        _HEAD,
        np.array([values[k] for k in _SCALARS]),
        p.hysteresis,
        p.creep,
        lambda tau: np.exp(-1.0 / (fs * tau)),
    )


def initial_state(kc: KernelConstants) -> np.ndarray:
    """At rest and discharged; the meter reads its offset."""
    state = np.zeros(kc.n_state)
    sc = kc.scalars
    state[3] = _quantise(sc[11], sc[10])
    return state


@numba.njit(cache=True)
def _quantise(value, step):
    return np.round(value / step) * step


@numba.njit(cache=True)
def run_kernel(mode, drive, noise, sc, C_h, v_h, creep_decay, creep_R, state, out):
    """Advance the bench over len(drive) samples; writes OUTPUTS into out and updates state.

    drive is V [V] in voltage mode (0) and the charging-current command i_c [A] in current
    mode (1); noise is the meter's noise [A] per sample (drawn outside so both paths share it).
    """
    C, R, c, G, u_max = sc[0], sc[1], sc[2], sc[3], sc[4]
    kp, ki, kd, fs, m_decay, m_res, m_off = sc[5], sc[6], sc[7], sc[8], sc[9], sc[10], sc[11]
    comp, comp_X, comp_R, comp_c = sc[12], sc[13], sc[14], sc[15]
    h = 1.0 / fs
    nh = C_h.size
    nc = creep_R.size
    q_b = state[_HEAD : _HEAD + nh]
    U_c = state[_HEAD + nh : _HEAD + nh + nc]
    Q, V, m, reading, integral, prev_e, has_prev = (
        state[0],
        state[1],
        state[2],
        state[3],
        state[4],
        state[5],
        state[6],
    )
    vmax = span(v_h)
    for n in range(drive.size):
        i_t = 0.0
        if mode == 1:
            i_c = drive[n]
            # feedforward block (Eq 13 / Eq 15), V = G·u of the previous sample
            if comp == 1:
                i_t = i_c + V / comp_X
            elif comp == 2:
                i_t = i_c + V / comp_R * math.sqrt((comp_c * i_c) ** 2 + 1.0)
            else:
                i_t = i_c
            e = i_t - reading
            de = (e - prev_e) / h if has_prev > 0.0 else 0.0
            new_integral = integral + e * h
            u_raw = kp * e + ki * new_integral + kd * de
            u = min(max(u_raw, -u_max), u_max)
            # conditional integration (CurrentPID): no wind-up into saturation
            if u != u_raw and np.sign(e) == np.sign(u_raw - u):
                new_integral = integral
            integral = new_integral
            prev_e = e
            has_prev = 1.0
            V = G * u
        else:
            V = min(max(drive[n], -G * u_max), G * u_max)
        uc_sum = 0.0
        for j in range(nc):
            uc_sum += U_c[j]
        # V = Q/C + U_H(Q) + ΣU_c is monotone in Q with |U_H| <= vmax
        target = V - uc_sum
        lo = C * (target - vmax) - 1e-9
        hi = C * (target + vmax) + 1e-9
        q = Q
        for _ in range(MAX_ITERATIONS):
            uh, slope = maxwell(q, q_b, C_h, v_h)
            f = q / C + uh - target
            if balanced(f, target):
                break
            q, lo, hi = newton_step(q, f, 1.0 / C + slope, lo, hi)
        uh = slide_and_sum(q, q_b, C_h, v_h)
        i_C = (q - Q) * fs
        i_l = V / R * math.sqrt((c * i_C) ** 2 + 1.0)
        current = i_C + i_l
        m = m * m_decay + (1.0 - m_decay) * current
        reading = _quantise(m + m_off + noise[n], m_res)
        out[n, 0] = V
        out[n, 1] = current
        out[n, 2] = reading
        out[n, 3] = q
        out[n, 4] = uh
        out[n, 5] = uc_sum
        out[n, 6] = i_t
        out[n, 7] = i_C
        out[n, 8] = i_l
        for j in range(nc):
            U_c[j] = U_c[j] * creep_decay[j] + i_C * creep_R[j] * (1.0 - creep_decay[j])
        Q = q
    state[0], state[1], state[2], state[3] = Q, V, m, reading
    state[4], state[5], state[6] = integral, prev_e, has_prev


def run(
    mode: str, drive: np.ndarray, noise: np.ndarray, kc: KernelConstants, state: np.ndarray
) -> np.ndarray:
    """Fast path: the numba kernel over one chunk; returns an (n, N_OUT) array."""
    out = np.empty((len(drive), N_OUT))
    run_kernel(
        MODES[mode],
        np.ascontiguousarray(drive, float),
        np.ascontiguousarray(noise, float),
        kc.scalars,
        kc.C_h,
        kc.v_h,
        kc.creep_decay,
        kc.creep_R,
        state,
        out,
    )
    return out


def run_reference(
    mode: str, drive: np.ndarray, noise: np.ndarray, kc: KernelConstants, state: np.ndarray
) -> np.ndarray:
    """Plain-Python reference of :func:`run_kernel`: Brent's method for the voltage balance, the
    library's :class:`~selfsense.methods.powerloss.CurrentPID` and Eq 13/15 from
    :mod:`selfsense.methods.powerloss`."""
    sc = dict(zip(_SCALARS, kc.scalars))
    q_b, U_c = kc.elements(state)
    Q, V, m, reading = state[:4]
    pid = pl.CurrentPID(sc["kp"], sc["ki"], sc["kd"], 1.0 / sc["fs"], -sc["u_max"], sc["u_max"])
    pid_state = pl.PIDState(state[4], state[5] if state[6] > 0 else None)
    comp = {v: k for k, v in COMPENSATIONS.items()}[int(sc["comp_kind"])]
    v_limit = sc["gain"] * sc["u_max"]
    out = np.empty((len(drive), N_OUT))

    def u_h(q):
        return maxwell_reference(q, q_b, kc.C_h, kc.v_h)

    for n in range(len(drive)):
        i_t = 0.0
        if mode == "current":
            i_c = drive[n]
            if comp == "impedance":
                i_t = i_c + V / sc["comp_X"]
            elif comp == "model_10":
                i_t = pl.compensated_current(i_c, V, sc["comp_R"], sc["comp_c"])
            else:
                i_t = i_c
            u, pid_state = pid.step(pid_state, i_t, reading)
            V = sc["gain"] * u
        else:
            V = float(np.clip(drive[n], -v_limit, v_limit))
        uc_sum = float(U_c.sum())
        target = V - uc_sum
        vmax = float(kc.v_h.sum())
        q = brentq(
            lambda q: q / sc["C"] + u_h(q) - target,
            sc["C"] * (target - vmax) - 1e-9,
            sc["C"] * (target + vmax) + 1e-9,
            xtol=1e-24,
            rtol=4 * np.finfo(float).eps,
        )
        slide_anchors_reference(q, q_b, kc.C_h, kc.v_h)
        i_C = (q - Q) * sc["fs"]
        i_l = float(pl.leakage_current(i_C, V, sc["R"], sc["c"]))
        current = i_C + i_l
        m = m * sc["meter_decay"] + (1.0 - sc["meter_decay"]) * current
        reading = float(
            np.round((m + sc["meter_offset"] + noise[n]) / sc["meter_resolution"])
            * sc["meter_resolution"]
        )
        out[n] = (V, current, reading, q, u_h(q), uc_sum, i_t, i_C, i_l)
        U_c[:] = U_c * kc.creep_decay + i_C * kc.creep_R * (1.0 - kc.creep_decay)
        Q = q
    state[:4] = Q, V, m, reading
    state[4] = pid_state.integral
    state[5] = 0.0 if pid_state.prev_error is None else pid_state.prev_error
    state[6] = 0.0 if pid_state.prev_error is None else 1.0
    return out


class BenderBench:
    """One run of the bender bench: the twin's state, the instruments and the RNG."""

    def __init__(
        self,
        params: BenderParams,
        fs: float,
        seed: np.random.SeedSequence,
        compensation: Compensation = Compensation(),
    ):
        self.p = params
        self.kc = kernel_constants(params, fs, compensation)
        self.state = initial_state(self.kc)
        rng = np.random.default_rng(seed)
        self.noise_rng = np.random.default_rng(rng.integers(2**63))
        ins = params.instruments
        self.x_drift = SlowProcess(rng, ins.x_drift, ins.x_drift_bandwidth)

    def step(self, t: np.ndarray, mode: str, drive: np.ndarray) -> tuple[dict, dict]:
        """Advance over the samples at times t; returns (measured channels, noiseless truth)."""
        ins, act, n = self.p.instruments, self.p.actuator, len(t)
        gauss = self.noise_rng.standard_normal
        out = run(mode, drive, ins.meter_noise * gauss(n), self.kc, self.state)
        V, I, I_meter, Q, U_H, U_c, _, i_C, i_l = out.T
        x = act.a * Q
        measured = {
            "U": V + ins.U_noise * gauss(n),
            "I": I_meter,
            # the command the operator gives the current drive: i_c (Eq 3); none in voltage mode
            "i_cmd": drive if mode == "current" else np.zeros(n),
            "x_disp": x + self.x_drift(t) + ins.x_noise * gauss(n),
        }
        truth = {
            "x": x,
            "Q": Q,
            "V": V,
            "U_H": U_H,
            "U_c": U_c,
            "I": I,
            "i_C": i_C,
            "i_l": i_l,
            "X": pl.get_impedance_model(10)(i_C, act.R, act.c),
        }
        return measured, truth


def simulate_bender_capture(
    path: Path | str,
    params: BenderParams,
    daq: DaqPlan,
    drive: Drive,
    compensation: Compensation,
    attrs: Mapping[str, object],
    seed: int,
    experiment: str,
    chunk_len: int = 1 << 16,
    truth_decimation: int = 12,
    compression: str | None = TWIN_COMPRESSION[0],
    complevel: int = TWIN_COMPRESSION[1],
) -> ScanReport:
    """Run one experiment on the bender twin and write its capture (atomically, chunk by chunk);
    returns its QC scan."""
    if drive.quantity not in MODES:
        raise ValueError(
            f"{experiment}: the bender is driven by voltage or current, not {drive.quantity!r}"
        )
    fs = daq.fs
    n = int(round(drive.duration * fs))
    specs = [channel_spec(c, *daq.ranges[c]) for c in daq.channels]
    bench = BenderBench(params, fs, experiment_seed(seed, experiment), compensation)
    all_attrs = (
        dict(attrs)
        | compensation.attrs()
        | {
            "experiment": experiment,
            "seed": int(seed),
            "fs": fs,
            "software_version": __version__,
            "source": "simulated",
            "drive_quantity": drive.quantity,
            "amplifier_gain": params.amplifier.gain,
        }
    )
    with CaptureWriter(
        path,
        all_attrs,
        specs,
        n,
        chunk_len=chunk_len,
        compression=compression,
        complevel=complevel,
        truth=TRUTH_STATES,
        truth_decimation=truth_decimation,
    ) as w:
        w.write_truth_attrs(params.truth_attrs())
        for start in range(0, n, chunk_len):
            t = (start + np.arange(min(chunk_len, n - start))) / fs
            measured, truth = bench.step(t, drive.quantity, drive(t))
            w.write({c: measured[c] for c in daq.channels})
            keep = (start + np.arange(len(t))) % truth_decimation == 0
            w.write({k: v[keep] for k, v in truth.items()}, dim="time_truth")
    return w.scan_report()


def compensation_of(
    experiment: Experiment, identified: Mapping[str, float] | None = None
) -> Compensation:
    """The feedforward setting of a catalogue experiment; ``identified``: the identified R and c
    an Eq 15 run ``{R: identified, c: identified}`` takes (:func:`identified_compensation`)."""
    try:
        return Compensation.from_protocol(experiment.compensation, identified)
    except ValueError as err:
        raise ValueError(f"{experiment.name}: {err}") from None


def simulate_experiment(
    path: Path | str,
    twin: Mapping[str, Any],
    daq: DaqPlan,
    experiment: Experiment,
    attrs: Mapping[str, object],
    seed: int,
    capture: Mapping[str, Any],
    compression: Mapping[str, Any],
    where: str = "twin",
    identified: Mapping[str, float] | None = None,
) -> ScanReport:
    """One catalogue experiment on the bender twin, as
    :func:`selfsense.twin.experiment.simulate_experiment` resolved it; ``identified``: the
    identified R and c of an Eq 15 run (:func:`identified_compensation`)."""
    compensation = compensation_of(experiment, identified)
    return simulate_bender_capture(
        path,
        BenderParams.from_manifest(twin, where),
        daq,
        drive_from_protocol(experiment.protocol),
        compensation,
        attrs,
        seed,
        experiment.name,
        chunk_len=capture["chunk_len"],
        truth_decimation=capture["truth_decimation"],
        **compression,
    )
