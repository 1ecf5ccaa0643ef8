"""The open-loop bench compiled: the stack and the instruments in one numba loop per chunk.

:func:`step` does what :meth:`.bench.Bench.step` (the reference) does for one chunk of open-loop
drive: the stack's response (:func:`.kernel.run_kernel`), then the instruments sample by sample
(ripple current through R_e–C_e, the ripple channels' high-pass, the probes' offsets and drifts,
the ADC), with the reference's operations in its order, so the captures are the reference's bit
for bit here; the twin's time-only signals (ripple carrier, drifts, noise) are made by
:meth:`.bench.Bench.time_signals` as before. The closed loop adds the self-sensing chain and the
controller to the same per-sample instruments (:mod:`.realtime`). The tests hold both to the
reference.
"""

from __future__ import annotations

import numba
import numpy as np

from ..lti import filter_step
from .kernel import N_OUT, run_kernel

#: measured channels in the loop's order (rows of its `measured` output)
MEASURED = ("U", "I", "Ur", "Ir", "x_laser", "F")
#: rows of the truth output, as bench.TRUTH_STATES
TRUTH = ("x", "q", "U_P", "U_H", "T", "C_P", "R_e", "I_offset", "U_drive")


@numba.njit(cache=True)
def _quantize(value, scale, offset):
    """ChannelSpec.quantize for one sample (scale 0: the channel is not recorded by the ADC)."""
    if scale == 0.0:
        return value
    code = np.rint((value - offset) / scale)
    return min(max(code, -32767.0), 32767.0) * scale + offset


@numba.njit(cache=True)
def record_sample(j, U, out, sig, bench, hp_b, hp_a, zi_u, zi_i, adc, measured, truth):
    """What the DAQ records at sample j, from the drive U and the stack's outputs ``out`` (a row
    of kernel.OUTPUTS): measured (quantised) and truth columns j, high-pass states updated.

    sig: the arrays f_r, u (complex ripple voltage), h (high-pass at f_r), I_offset, laser_drift and
    the noise of each MEASURED channel (signal_arrays).
    bench: R_ref, R_slope, C_ref, F_preload, k_spring + load, m, T_amb.
    adc: (scale, offset) per MEASURED channel.
    """
    x, a, q, U_P, U_H, T, I, C_P = out[0], out[2], out[3], out[4], out[5], out[6], out[7], out[8]
    R_e = bench[0] + bench[1] * (C_P - bench[2])  # instruments.effective_resistance
    ur, h = sig[1][j], sig[2][j]
    i_r = ur * (1.0 / (R_e + 1.0 / (1j * 2 * np.pi * sig[0][j] * C_P)))  # RippleSource.current
    leak_u = filter_step(U, hp_b, hp_a, zi_u)
    leak_i = filter_step(I, hp_b, hp_a, zi_i)
    values = (U + ur.real + sig[5][j],
              I + i_r.real + sig[3][j] + sig[6][j],
              (ur * h).real + leak_u + sig[7][j],
              (i_r * h).real + leak_i + sig[8][j],
              x + sig[4][j] + sig[9][j],
              bench[3] + bench[4] * x + bench[5] * a + sig[10][j])
    for c in range(6):
        measured[c, j] = _quantize(values[c], adc[c, 0], adc[c, 1])
    truth[0, j], truth[1, j], truth[2, j], truth[3, j], truth[4, j] = x, q, U_P, U_H, T
    truth[5, j], truth[6, j], truth[7, j], truth[8, j] = C_P, R_e, sig[3][j], U


@numba.njit(cache=True)
def open_loop_kernel(U, sig, bench, sc, C_h, v_h, creep_decay, creep_R, state, hp_b, hp_a, zi_u, zi_i, adc,
                     measured, truth):
    """The stack over the chunk's drive U, then the instruments sample by sample (see record_sample)."""
    n = U.size
    out = np.empty((n, N_OUT))
    run_kernel(U, np.zeros(n), np.full(n, bench[6]), sc, C_h, v_h, creep_decay, creep_R, state, out)
    for j in range(n):
        record_sample(j, U[j], out[j], sig, bench, hp_b, hp_a, zi_u, zi_i, adc, measured, truth)


def bench_arrays(bench, signals) -> tuple[tuple[np.ndarray, ...], np.ndarray, np.ndarray]:
    """The (sig, bench, adc) arguments of :func:`record_sample` for a :class:`.bench.Bench` and its
    :meth:`~.bench.Bench.time_signals` (the signals as they are: stacking them cost a sixth of a
    simulation)."""
    from .instruments import effective_resistance

    p = bench.p
    sig = tuple(np.ascontiguousarray(signals[k]) for k in ("f_r", "u_ripple", "h", "I_offset", "laser_drift",
                                                            *(f"noise_{c}" for c in MEASURED)))
    rp = p.ripple
    constants = np.array([float(effective_resistance(np.float64(rp.C_ref), rp)), rp.R_slope, rp.C_ref,
                          p.instruments.F_preload, p.stack.k_spring + bench.load_stiffness, p.stack.m, bench.T_amb])
    adc = np.array([(bench.adc[c].scale_factor, bench.adc[c].add_offset) if c in bench.adc else (0.0, 0.0)
                    for c in MEASURED])
    return sig, constants, adc


def step(bench, t: np.ndarray, U: np.ndarray) -> tuple[dict, dict]:
    """:meth:`.bench.Bench.step` (open loop, no external force) through :func:`open_loop_kernel`;
    returns (measured, truth) as it does."""
    n, kc = len(t), bench.kc
    sig, constants, adc = bench_arrays(bench, bench.time_signals(t))
    measured, truth = np.empty((6, n)), np.empty((9, n))
    # both ripple channels' filters have the same coefficients
    open_loop_kernel(np.ascontiguousarray(U, float), sig, constants, kc.scalars, kc.C_h, kc.v_h, kc.creep_decay,
                     kc.creep_R, bench.state, bench.hp_u.b, bench.hp_u.a, bench.hp_u.zi, bench.hp_i.zi, adc,
                     measured, truth)
    return dict(zip(MEASURED, measured)), dict(zip(TRUTH, truth))
