"""What the DAQ records, compiled: the instruments of :meth:`.bench.Bench._instruments` over a
block of samples in one numba function, which the open-loop bench and the closed loop
(:mod:`.realtime`) share.

From the drive U and the stack's outputs (a block of :data:`.kernel.OUTPUTS` rows) it makes the
ripple current through the series R_e–C_e (Eq 3.12's quantities, :func:`.instruments.small_signal`),
the ripple channels' high-pass with the drive's leak, the probes' offsets, resolutions and noise,
the ADC's quantisation, and the noiseless states of /truth. The numpy reference does the same
operations on whole arrays in the same order, so the two agree bit for bit (the tests hold them
to it); a chunk's arithmetic in one pass costs about a third of numpy's, whose every operation
walks the chunk's arrays again.
"""

from __future__ import annotations

import numba
import numpy as np

from selfsense.twin.instruments import effective_resistance

#: measured channels in the recorder's order (rows of its ``measured`` output)
#: the channels recorded with a noise of their own and its parameter [rms]; the current probe and
#: the laser are specified by their resolution instead (:func:`.instruments.resolve`)
NOISY = {"U": "U_noise", "Ur": "ripple_noise_U", "Ir": "ripple_noise_I", "F": "F_noise"}

MEASURED = ("U", "I", "Ur", "Ir", "x_laser", "F")
#: rows of the truth output: the noiseless states a simulated capture keeps in /truth (every
#: ``truth_decimation``-th sample)
TRUTH = ("x", "q", "U_P", "U_H", "T", "C_P", "C_e", "R_e", "I_offset", "U_drive")


@numba.njit(cache=True)
def _quantize(value, step, offset, full):
    """ChannelSpec.quantize for one sample (step 0: the channel is not recorded by the ADC)."""
    if step == 0.0:
        return value
    code = np.rint((value - offset) / step)
    return min(max(code, -full), full) * step + offset


@numba.njit(cache=True)
def _resolve(value, resolution):
    """instruments.resolve for one sample."""
    return resolution * np.rint(value / resolution) if resolution else value


@numba.njit(cache=True)
def _leaks(b, a, x1, x2, z1, z2, y1, y2):
    """The drive's and the current's leak through the ripple channels' high-pass: lti.filter_run's
    arithmetic for the two second-order sections side by side, their states in registers (through
    the state arrays, one filter after the other, they took half the recording's time)."""
    p0, p1, q0, q1 = z1[0], z1[1], z2[0], z2[1]
    b0, b1, b2, a1, a2 = b[0], b[1], b[2], a[1], a[2]
    for n in range(x1.size):
        u, v = x1[n], x2[n]
        yu = p0 + b0 * u
        yv = q0 + b0 * v
        p0 = p1 + u * b1 - yu * a1
        q0 = q1 + v * b1 - yv * a1
        p1 = u * b2 - yu * a2
        q1 = v * b2 - yv * a2
        y1[n], y2[n] = yu, yv
    z1[0], z1[1], z2[0], z2[1] = p0, p1, q0, q1


@numba.njit(cache=True)
def _small_signal(C_P, U_H, bench):
    """instruments.small_signal for one sample: C_e and R_e."""
    C_e = C_P + bench[7] * U_H
    return C_e, bench[0] + bench[1] * (C_e - bench[2]) + bench[8] * U_H


@numba.njit(cache=True)
def record_block(
    j0, U, out, sig, bench, hp_b, hp_a, zi_u, zi_i, adc, measured, truth, every, first
):
    """What the DAQ records at samples j0 … j0 + len(U) − 1 of a chunk, from the block's drive U and
    the stack's outputs ``out`` (len(U) rows of kernel.OUTPUTS): measured (quantised) columns j0 …,
    the high-pass states zi_u, zi_i carried, and the truth of the samples first, first + every, …
    of the chunk in truth's columns 0, 1, … (written only there: ten rows at every sample cost
    more than the rest of the recording).

    sig: the chunk's arrays f_r, u (complex ripple voltage), h (high-pass at f_r), I_offset,
    laser_drift and the noise of each channel of :data:`NOISY`, in its order (U, Ur, Ir, F).
    bench: R_ref, R_slope, C_ref, F_preload, k_spring + load, m, T_amb, dC_H, dR_H, the current
    probe's and the laser's resolution, the current probe's gain at the ripple frequency.
    adc: (step, offset, full code) per MEASURED channel.
    """
    f_r, ur, h, I_off, drift, nU, nUr, nIr, nF = sig
    n = U.size
    stop = j0 + n
    # the drive's leak through the ripple channels' high-pass, parked in their rows
    _leaks(hp_b, hp_a, U, out[:, 7], zi_u, zi_i, measured[2, j0:stop], measured[3, j0:stop])
    for k in range(n):
        j = j0 + k
        x, a, I = out[k, 0], out[k, 2], out[k, 7]
        C_e, R_e = _small_signal(out[k, 8], out[k, 5], bench)
        i_r = ur[j] * (1.0 / (R_e + 1.0 / (1j * 2 * np.pi * f_r[j] * C_e)))  # RippleSource.current
        measured[0, j] = U[k] + ur[j].real + nU[j]
        i_r *= bench[11]  # the current probe's gain at the ripple frequency
        measured[1, j] = _resolve(I + i_r.real + I_off[j], bench[9])
        measured[2, j] = (ur[j] * h[j]).real + measured[2, j] + nUr[j]
        measured[3, j] = (i_r * h[j]).real + measured[3, j] + nIr[j]
        measured[4, j] = _resolve(x + drift[j], bench[10])
        measured[5, j] = bench[3] + bench[4] * x + bench[5] * a + nF[j]
    for j in range(first + -(-(j0 - first) // every) * every, stop, every):
        k, i = j - j0, (j - first) // every
        C_e, R_e = _small_signal(out[k, 8], out[k, 5], bench)
        truth[0, i], truth[1, i], truth[2, i], truth[3, i], truth[4, i] = (
            out[k, 0],
            out[k, 3],
            out[k, 4],
            out[k, 5],
            out[k, 6],
        )
        truth[5, i], truth[6, i], truth[7, i], truth[8, i], truth[9, i] = (
            out[k, 8],
            C_e,
            R_e,
            I_off[j],
            U[k],
        )
    for c in range(len(MEASURED)):  # a pass per channel: faster than six channels at every sample
        step, offset, full = adc[c, 0], adc[c, 1], adc[c, 2]
        for j in range(j0, stop):
            measured[c, j] = _quantize(measured[c, j], step, offset, full)


def bench_arrays(bench, signals) -> tuple[tuple[np.ndarray, ...], np.ndarray, np.ndarray]:
    """The (sig, bench, adc) arguments of :func:`record_block` for a :class:`.bench.Bench` and its
    :meth:`~.bench.Bench.time_signals` (the signals as they are: stacking them cost as much as the
    loop)."""
    p, ins = bench.p, bench.p.instruments
    if len(bench.hp_u.a) != 3:  # record_block's _leaks is written for the 2nd-order Sallen-Key
        raise ValueError(
            f"the ripple high-pass has order {len(bench.hp_u.a) - 1}; the recorder takes 2"
        )
    sig = tuple(
        np.ascontiguousarray(signals[k])
        for k in ("f_r", "u_ripple", "h", "I_offset", "laser_drift", *(f"noise_{c}" for c in NOISY))
    )
    rp = p.ripple
    constants = np.array(
        [
            float(effective_resistance(np.float64(rp.C_ref), rp)),
            rp.R_slope,
            rp.C_ref,
            ins.F_preload,
            p.stack.k_spring + bench.load_stiffness,
            p.stack.m,
            bench.T_amb,
            rp.dC_H,
            rp.dR_H,
            ins.I_resolution,
            ins.laser_resolution,
            ins.I_probe_gain_at_ripple,
        ]
    )
    adc = np.array(
        [
            (bench.adc[c].step, bench.adc[c].add_offset, float(bench.adc[c].full_code))
            if c in bench.adc
            else (0.0, 0.0, 0.0)
            for c in MEASURED
        ]
    )
    return sig, constants, adc


def record(
    bench, U: np.ndarray, out: np.ndarray, signals, every: int = 1, first: int = 0
) -> tuple[dict, dict]:
    """A whole chunk through :func:`record_block`, from and back into ``bench``'s high-pass states;
    returns (measured, truth) as :meth:`.bench.Bench.step` does, the truth at the chunk's samples
    first, first + every, …"""
    n = len(U)
    sig, constants, adc = bench_arrays(bench, signals)
    measured, truth = (
        np.empty((len(MEASURED), n)),
        np.empty((len(TRUTH), len(range(first, n, every)))),
    )
    record_block(
        0,
        np.ascontiguousarray(U, float),
        out,
        sig,
        constants,
        bench.hp_u.b,
        bench.hp_u.a,
        bench.hp_u.zi,
        bench.hp_i.zi,
        adc,
        measured,
        truth,
        every,
        first,
    )
    return dict(zip(MEASURED, measured)), dict(zip(TRUTH, truth))
