"""The bench: drive → stack physics → instruments → DAQ capture, generated chunk by chunk.

`simulate_capture` writes one experiment's capture through :mod:`selfsense.io.capture`. Memory
stays flat in the capture's length: each chunk is generated, written and dropped.

Real-time control hook: pass a ``controller`` (see :class:`Controller`) and the bench runs in
blocks of ``controller.block_len`` samples; before each block the controller chooses the drive
voltage from what it has observed so far, after it the controller sees the block's measured
channels and returns the signals it logs (``x_ref``, ``x_hpo_rt``, ``u_cmd``), which go into
the capture as the bench's real-time logs. A controller whose ``compiled`` is true (the HPO
loop of Chapter 6) runs the engaged samples of a chunk in one numba loop instead, through its
``run_blocks(bench, t, signals)`` (:mod:`.realtime`), which the tests hold to this per-block
reference.
"""

from __future__ import annotations

import math
import zlib as _zlib
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Protocol

import numpy as np

from selfsense import __version__
from selfsense.io.capture import (
    SLOW_CHANNELS,
    TWIN_COMPRESSION,
    CaptureWriter,
    ScanReport,
    channel_spec,
)
from selfsense.methods.drive import Drive
from selfsense.twin import kernel
from selfsense.twin.instruments import (
    Amplifier,
    HighPass,
    RippleSource,
    SlowProcess,
    resolve,
    small_signal,
)
from selfsense.twin.params import TwinParams
from selfsense.twin.record import NOISY, TRUTH, record
from selfsense.twin.variants import Delay, PowerAmplifier, series_load


@dataclass(frozen=True)
class DaqPlan:
    """What the DAQ records and how: rates, channels and their ADC ranges."""

    fs: float
    channels: tuple[str, ...]
    ranges: Mapping[str, tuple[float, float]]
    fr_nominal: float | None = None
    ns: int | None = None
    nf: int | None = None
    n_periods: int | None = None


class Controller(Protocol):
    """The real-time controller interface the closed-loop experiments plug in."""

    block_len: int
    logs: tuple[str, ...]
    engage_at: float  # [s] before this the loop is open (U = 0) and the controller only observes

    def command(self, t: np.ndarray) -> np.ndarray:
        """Drive voltage for the block starting at t[0] (from what was observed before it)."""

    def observe(
        self, t: np.ndarray, measured: Mapping[str, np.ndarray]
    ) -> Mapping[str, np.ndarray]:
        """See one block of measured channels; return the block's real-time logs."""


def experiment_seed(seed: int, experiment: str) -> np.random.SeedSequence:
    """A seed per (dataset seed, experiment): captures differ across experiments, repeat exactly."""
    return np.random.SeedSequence([int(seed), _zlib.crc32(experiment.encode())])


class Bench:
    """One run of the bench: owns the twin's state, the instruments' state and the RNG."""

    def __init__(
        self,
        params: TwinParams,
        daq: DaqPlan,
        seed: np.random.SeedSequence,
        load_stiffness: float = 0.0,
        T_amb: float | None = None,
        drive_leak: bool = True,
    ):
        self.p = params
        self.daq = daq
        rng = np.random.default_rng(seed)
        self.noise_rng = np.random.default_rng(rng.integers(2**63))
        # the load the stack pushes on, through the load path's compliance (the force sensor
        # reads the force that crosses it)
        load_stiffness = series_load(load_stiffness, params.load_path.compliance)
        self.kc = kernel.kernel_constants(params, daq.fs, load_stiffness)
        self.T_amb = params.thermal.T_amb if T_amb is None else T_amb
        self.state = kernel.initial_state(self.kc, self.T_amb)
        self.load_stiffness = load_stiffness
        # the real-time loop and the capture both see the ADC's quantised values
        ins = params.instruments
        self.adc = {
            c: channel_spec(c, *daq.ranges[c], bits=ins.adc_bits)
            for c in daq.channels
            if c not in SLOW_CHANNELS
        }
        self.ripple = RippleSource(params.ripple, daq.fs, rng)
        rp = params.ripple
        self.hp_u = HighPass(rp.highpass_hz, daq.fs, rp.highpass_q)
        self.hp_i = HighPass(rp.highpass_hz, daq.fs, rp.highpass_q)
        # a what-if for studies (selfsense.verify.loop_leak): the ripple channels see the
        # ripple alone
        if not drive_leak:
            self.hp_u.b = self.hp_i.b = np.zeros_like(self.hp_u.b)
        self.delay = Delay(params.loop.delay_samples)
        self.amplifier = (
            PowerAmplifier(params.power_amplifier, daq.fs)
            if params.power_amplifier.on
            else Amplifier(ins.amplifier_gain_at_folded_ripple, daq.fs, daq.ns)
        )
        self.offset_drift = SlowProcess(rng, ins.I_offset_drift, ins.I_offset_drift_bandwidth)
        self.laser_drift = SlowProcess(rng, ins.laser_drift, ins.laser_drift_bandwidth)

    def time_signals(self, t: np.ndarray, compiled: bool = True) -> dict[str, np.ndarray]:
        """What the instruments add that depends on time alone: the ripple's frequency and voltage
        and the high-pass's response to it, the probe offset, the laser's drift and the noise of
        the channels :data:`NOISY` lists, in this order of random draws. The closed loop makes
        them once per chunk and steps the bench through it block by block (:meth:`step`'s
        ``signals``). ``compiled``: the ripple's carrier and the high-pass's response by the numba
        loops of :mod:`.instruments`, else by their numpy references (the same values, bit for
        bit)."""
        ins, n, gauss = self.p.instruments, len(t), self.noise_rng.standard_normal
        f_r, u = self.ripple.carrier(t, compiled)
        return {
            "f_r": f_r,
            "u_ripple": u,
            "h": self.hp_u.response(f_r, compiled),
            "I_offset": ins.I_offset + self.offset_drift(t),
            "laser_drift": self.laser_drift(t),
            **{f"noise_{c}": getattr(ins, NOISY[c]) * gauss(n) for c in NOISY},
        }

    def step(
        self,
        t: np.ndarray,
        U: np.ndarray,
        F_ext: np.ndarray | None = None,
        signals: Mapping[str, np.ndarray] | None = None,
        truth_every: int = 1,
        truth_first: int = 0,
        compiled: bool = True,
    ):
        """Advance over the samples at times t with the command U (through the DAQ's output
        latency, if any, to the amplifier, whose output drives the stack and is what the U channel
        records); returns (measured, truth) dicts, the truth
        at samples truth_first, truth_first + truth_every, … of these.

        ``signals``: :meth:`time_signals` of exactly these samples, made beforehand (by default
        they are made here). ``compiled``: the time-only signals and the instruments in numba
        (:func:`.record.record_block`), or else in numpy (:meth:`_instruments`, the reference
        the tests hold it to).
        """
        n = len(t)
        F_ext = np.zeros(n) if F_ext is None else F_ext
        sig = self.time_signals(t, compiled) if signals is None else signals
        U = self.amplifier(self.delay(U))
        out = kernel.run(U, F_ext, np.full(n, self.T_amb), self.kc, self.state)
        if compiled:
            return record(self, U, out, sig, truth_every, truth_first)
        measured, truth = self._instruments(U, out, sig)
        return measured, {k: v[truth_first::truth_every] for k, v in truth.items()}

    def _instruments(self, U: np.ndarray, out: np.ndarray, sig: Mapping[str, np.ndarray]):
        """The numpy reference of :func:`.record.record`: what the DAQ records from the drive U and
        the stack's outputs ``out`` (rows of kernel.OUTPUTS), and the truth at every sample."""
        x, v, a, q, U_P, U_H, T, I, C_P = out.T
        u, h, ins = sig["u_ripple"], sig["h"], self.p.instruments
        C_e, R_e = small_signal(C_P, U_H, self.p.ripple)
        i = self.ripple.current(sig["f_r"], u, C_e, R_e) * ins.I_probe_gain_at_ripple
        measured = {
            "U": U + u.real + sig["noise_U"],
            "I": resolve(I + i.real + sig["I_offset"], ins.I_resolution),
            "Ur": (u * h).real + self.hp_u.leak(U) + sig["noise_Ur"],
            "Ir": (i * h).real + self.hp_i.leak(I) + sig["noise_Ir"],
            "x_laser": resolve(x + sig["laser_drift"], ins.laser_resolution),
            "F": (
                ins.F_preload
                + (self.p.stack.k_spring + self.load_stiffness) * x
                + self.p.stack.m * a
                + sig["noise_F"]
            ),
        }
        measured = {c: self.adc[c].quantize(v) if c in self.adc else v for c, v in measured.items()}
        truth = {
            "x": x,
            "q": q,
            "U_P": U_P,
            "U_H": U_H,
            "T": T,
            "C_P": C_P,
            "C_e": C_e,
            "R_e": R_e,
            "I_offset": sig["I_offset"],
            "U_drive": U,
        }
        return measured, truth

    def temperatures(self, T: np.ndarray) -> dict[str, np.ndarray]:
        """The three IR thermometers: each sees its share of the rise above ambient, plus noise."""
        ins = self.p.instruments
        rise = T - self.T_amb
        return {
            name: self.T_amb + share * rise + ins.T_noise * self.noise_rng.standard_normal(len(T))
            for name, share in zip(("T_top", "T_mid", "T_bot"), ins.T_gradient)
        }


def simulate_capture(
    path: Path | str,
    params: TwinParams,
    daq: DaqPlan,
    drive: Drive,
    attrs: Mapping[str, object],
    seed: int,
    experiment: str,
    load_stiffness: float = 0.0,
    controller: Controller | None = None,
    chunk_len: int = 1 << 16,
    truth_decimation: int = 12,
    compression: str | None = TWIN_COMPRESSION[0],
    complevel: int = TWIN_COMPRESSION[1],
    drive_leak: bool = True,
) -> ScanReport:
    """Run one experiment on the twin and write its capture (atomically); returns its QC scan.
    ``drive_leak=False``: :class:`Bench`'s what-if, the drive kept out of the ripple channels."""
    fs = daq.fs
    n = int(round(drive.duration * fs))
    fast = [c for c in daq.channels if c not in SLOW_CHANNELS]
    slow = [c for c in daq.channels if c in SLOW_CHANNELS]
    slow_every = int(round(fs / params.instruments.T_rate)) if slow else 0
    n_slow = -(-n // slow_every) if slow else 0
    if controller is not None:
        fast += [c for c in controller.logs if c not in fast]
        chunk_len = controller.block_len * max(1, chunk_len // controller.block_len)
    specs = [channel_spec(c, *daq.ranges[c]) for c in fast + slow]
    bench = Bench(
        params, daq, experiment_seed(seed, experiment), load_stiffness, drive_leak=drive_leak
    )
    k_over_alpha = params.stack.k / params.stack.alpha
    all_attrs = dict(attrs) | {
        "experiment": experiment,
        "seed": int(seed),
        "fs": fs,
        "software_version": __version__,
        "source": "simulated",
        "drive_quantity": drive.quantity,
    }
    for key in ("fr_nominal", "ns", "nf", "n_periods"):
        if getattr(daq, key) is not None:
            all_attrs[key] = getattr(daq, key)
    path = Path(path)
    with CaptureWriter(
        path,
        all_attrs,
        specs,
        n,
        n_slow,
        params.instruments.T_rate,
        chunk_len=chunk_len,
        compression=compression,
        complevel=complevel,
        truth=TRUTH,
        truth_decimation=truth_decimation,
    ) as w:
        w.write_truth_attrs(params.truth_attrs())
        # the states are recorded at the samples on a grid that holds both the truth's and the
        # thermometers' samples (the truth's own when they share it, as at 48 kHz, 12 and 10 Hz)
        grid = math.gcd(truth_decimation, slow_every) if slow else truth_decimation
        for start in range(0, n, chunk_len):
            t = (start + np.arange(min(chunk_len, n - start))) / fs
            reference = drive(t)
            first = -start % grid  # the chunk's first sample on the grid
            if controller is None:
                U = reference * k_over_alpha if drive.quantity == "position" else reference
                measured, states = bench.step(t, U, truth_every=grid, truth_first=first)
            else:
                measured, states, logs = _closed_loop_chunk(bench, controller, t)
                measured |= logs
                states = {k: v[first::grid] for k, v in states.items()}
            w.write({c: measured[c] for c in fast})
            w.write(
                {k: _every(v, start + first, grid, truth_decimation) for k, v in states.items()},
                dim="time_truth",
            )
            if slow:
                w.write(
                    bench.temperatures(_every(states["T"], start + first, grid, slow_every)),
                    dim="time_slow",
                )
    return w.scan_report()


def _every(values: np.ndarray, origin: int, grid: int, period: int) -> np.ndarray:
    """Of ``values`` at samples origin, origin + grid, … (origin a multiple of grid, which divides
    period), those at the multiples of ``period``."""
    return values[(-origin % period) // grid :: period // grid]


def _closed_loop_chunk(bench: Bench, controller: Controller, t: np.ndarray):
    """Step the bench block by block under the controller (one block of delay, as a DAQ loop)."""
    parts: list[tuple[dict, dict, Mapping]] = []
    idle = int(np.count_nonzero(t < controller.engage_at))
    if idle:  # loop still open: one step for the whole stretch, the controller only observes
        measured, truth = bench.step(t[:idle], np.zeros(idle))
        parts.append((measured, truth, controller.observe(t[:idle], measured)))
    b, rest = controller.block_len, t[idle:]
    signals = bench.time_signals(
        rest
    )  # once for the chunk: per 12-sample block they cost a third of a step
    if getattr(controller, "compiled", False) and len(rest):
        parts.append(controller.run_blocks(bench, rest, signals))
        return tuple(
            {k: np.concatenate([p[i][k] for p in parts]) for k in parts[0][i]} for i in range(3)
        )
    for s in range(0, len(rest), b):
        tb = rest[s : s + b]
        measured, truth = bench.step(
            tb, controller.command(tb), signals={k: v[s : s + b] for k, v in signals.items()}
        )
        parts.append((measured, truth, controller.observe(tb, measured)))
    return tuple(
        {k: np.concatenate([p[i][k] for p in parts]) for k in parts[0][i]} for i in range(3)
    )
