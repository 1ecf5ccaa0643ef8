"""The closed-loop bench compiled: stack, instruments, self-sensing chain and controller in one
numba loop (Chapter 6).

:func:`run_blocks` does over a stretch of engaged samples what the Python reference does block by
block (:func:`.bench._closed_loop_chunk` with
:class:`selfsense.twin.closed_loop.HPOIntegralController`, whose ``run_blocks`` calls it): the
controller's command from the errors of the block before (Eq 6.1–6.3), the DAQ's output
latency (:class:`.variants.Delay`, if any), the amplifier's (:class:`.instruments.Amplifier`,
unless ideal, or the power amplifier of :class:`.variants.PowerAmplifier`), the stack's response
(:func:`.kernel.run_kernel`), the instruments as :meth:`.bench.Bench.step` makes them
(:func:`.record.record_block` over the block: ripple current through R_e–C_e, the ripple channels'
high-pass, the probes' offsets and drifts, the ADC), then, sample by sample, the real-time chain on
the quantised channels: folded-bin Fourier sums over np periods (Eq 3.6–3.7), C_e (Eq 3.12),
x_CP = Γ(C_e) (Eq 5.4) held until the next window, and the HPO (Eq 5.5–5.9,
:func:`selfsense.methods.observer.hpo_update`). The reference's operations in its order, so the
captures are the reference's bit for bit here; the twin's time-only signals (ripple carrier,
drifts, noise) are made beforehand by :meth:`.bench.Bench.time_signals`, as the reference makes
them once per chunk. Every state lives in the Python objects before and after, so the two paths can
take turns; the tests hold this loop to the reference. The open-loop twin imports no self-sensing
code.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from selfsense.methods.lti import filter_run
from selfsense.methods.observer import hpo_update
from selfsense.twin.kernel import N_OUT, run_kernel
from selfsense.twin.record import MEASURED, TRUTH, bench_arrays, record_block
from selfsense.twin.variants import delay_run, rate_limited


@numba.njit(cache=True)
def closed_loop_kernel(
    t_ref,
    sig,
    bench,
    sc,
    C_h,
    v_h,
    creep_decay,
    creep_R,
    state,
    hp_b,
    hp_a,
    zi_u,
    zi_i,
    adc,
    amp,
    amp_z,
    delay,
    weights,
    tail,
    sums,
    gamma,
    hpo,
    hpo_state,
    loop,
    pending,
    measured,
    truth,
    logs,
):
    """Advance the closed loop over len(t_ref) samples, block by block; see the module docstring.

    sig, bench, adc: as record.record_block. amp: the amplifier's [ideal, b0, b1, 1, a1,
    rate limited, gain, max step, low, high] (:class:`.instruments.Amplifier`, or the power
    amplifier's stage, :class:`.variants.PowerAmplifier`), amp_z its state. delay: the commands
    in flight through the DAQ's output latency (:class:`.variants.Delay`; empty: none). weights:
    sin and cos rows (ns).
    tail: (2, ns) samples of the open period; sums: (4, np − 1) last whole periods' sums, oldest
    first. gamma: b0..bj [µm/µF^i]. hpo: Ad, Bd, Cd, Dd stacked (4, 2, 2).
    loop: [block_len, K_I, fs, u, u_lo, u_hi, x_cp, n, masked, tail_len, sums_len, fr, g, T, np,
    pending_len, Î0 of the last sample].
    Writes measured (6, n), truth (10, n), logs (x_ref, x_hpo_rt, u_cmd) and updates every state.
    """
    n = t_ref.size
    b = int(loop[0])
    K_I, fs, u, u_lo, u_hi = loop[1], loop[2], loop[3], loop[4], loop[5]
    x_cp, done, masked = loop[6], loop[7], loop[8]
    tail_len, sums_len = int(loop[9]), int(loop[10])
    omega_r = 2 * math.pi * loop[11]
    g_T, temperature, n_periods = loop[12], loop[13], int(loop[14])
    pend_len = int(loop[15])
    ns = weights.shape[1]
    Ad, Bd, Cd, Dd = hpo[0], hpo[1], hpo[2], hpo[3]
    out = np.empty((b, N_OUT))
    U = np.empty(b)
    D = U if delay.size == 0 else np.empty(b)  # the command after the DAQ's output latency
    V = D if amp[0] else np.empty(b)  # the stack's voltage: the amplifier's output
    zeros = np.zeros(b)
    ambient = np.full(b, bench[6])
    window = np.empty(4)
    i0_hat = loop[16]
    for s in range(0, n, b):
        nb = min(b, n - s)
        # the command: integrator steps of the block before, clipped at the amplifier's limits
        acc = 0.0
        for k in range(nb):
            if k < pend_len:
                acc += pending[k]
            U[k] = min(max(u + acc, u_lo), u_hi)
        if nb:
            u = U[nb - 1]
        if delay.size:
            delay_run(U[:nb], delay, D[:nb])
        if amp[5]:  # the power amplifier's rate-limited stage (twin.variants)
            rate_limited(D[:nb], amp[6:10], amp_z, V[:nb])
        elif not amp[0]:
            filter_run(amp[1:3], amp[3:5], D[:nb], amp_z, V[:nb])
        run_kernel(
            V[:nb], zeros[:nb], ambient[:nb], sc, C_h, v_h, creep_decay, creep_R, state, out[:nb]
        )
        record_block(
            s, V[:nb], out[:nb], sig, bench, hp_b, hp_a, zi_u, zi_i, adc, measured, truth, 1, 0
        )
        for k in range(nb):
            j = s + k
            # the real-time chain sees this sample with the x_CP of windows ended before it
            current = measured[1, j] if np.isfinite(measured[1, j]) else 0.0
            x_hat, i0_hat = hpo_update(Ad, Bd, Cd, Dd, hpo_state, current, x_cp)
            tail[0, tail_len] = measured[2, j]
            tail[1, tail_len] = measured[3, j]
            tail_len += 1
            if tail_len == ns:  # a folded period is complete: its sums, and a window once np are in
                tail_len = 0
                full = sums_len == n_periods - 1
                for r in range(4):
                    period = 0.0
                    for i in range(ns):
                        period += tail[r // 2, i] * weights[r % 2, i]
                    if full:  # oldest first, as ripple._moving_sum
                        total = sums[r, 0] if sums_len else period
                        for i in range(1, sums_len):
                            total += sums[r, i]
                        if sums_len:
                            total += period
                            for i in range(sums_len - 1):
                                sums[r, i] = sums[r, i + 1]
                            sums[r, sums_len - 1] = period
                        window[r] = total / (2 * n_periods)
                    else:
                        sums[r, sums_len] = period
                if not full:
                    sums_len += 1
                else:
                    A_V, B_V, A_I, B_I = window[0], window[1], window[2], window[3]
                    C_e = -(A_I * A_I + B_I * B_I) / (omega_r * (A_I * B_V - A_V * B_I))
                    c_uf = C_e * 1e6
                    x_um = gamma[gamma.size - 1] + c_uf * 0.0  # numpy's polyval (Γ, Eq 5.4)
                    for i in range(gamma.size - 2, -1, -1):
                        x_um = gamma[i] + x_um * c_uf
                    if g_T != 0.0:
                        x_um = x_um + g_T * temperature
                    if np.isfinite(x_um):
                        x_cp = x_um / 1e6
                    else:  # a window without ripple keeps the x_CP before it
                        masked += 1
            logs[0, j] = t_ref[j]
            logs[1, j] = x_hat
            logs[2, j] = U[k]
            pending[k] = K_I * (t_ref[j] - x_hat) / fs
        pend_len = nb
        done += nb
    loop[3], loop[6], loop[7], loop[8] = u, x_cp, done, masked
    loop[9], loop[10], loop[15], loop[16] = tail_len, sums_len, pend_len, i0_hat


def run_blocks(bench, controller, t: np.ndarray, signals) -> tuple[dict, dict, dict]:
    """The engaged stretch t of a chunk through :func:`closed_loop_kernel`, from and back into the
    state of ``bench`` (a :class:`.bench.Bench`) and ``controller`` (an
    :class:`selfsense.twin.closed_loop.HPOIntegralController`); returns (measured, truth, logs) as
    :meth:`.bench.Bench.step` and the controller's ``observe`` do."""
    n, chain = len(t), controller.chain
    windows, obs = chain.extractor._windows, chain.observer
    ns, n_periods = windows.ns, windows.n_periods
    sig, constants, adc = bench_arrays(bench, signals)
    tail = np.zeros((2, ns))
    tail_len = windows._tail.shape[1]
    tail[:, :tail_len] = windows._tail
    sums = np.zeros((4, max(n_periods - 1, 1)))
    sums_len = windows._period_sums.shape[1]
    sums[:, :sums_len] = windows._period_sums
    pending = np.zeros(controller.block_len)
    pend_len = min(len(controller.pending), controller.block_len)
    pending[:pend_len] = controller.pending[:pend_len]
    loop = np.array(
        [
            controller.block_len,
            controller.gains.K_I,
            controller.fs,
            controller.u,
            *controller.u_limits,
            chain.x_cp,
            chain.n,
            chain.masked_windows,
            tail_len,
            sums_len,
            chain.extractor.plan.fr,
            chain.gamma.g,
            chain.temperature,
            n_periods,
            pend_len,
            obs.last_offset,
        ],
        dtype=float,
    )
    measured, truth, logs = np.empty((6, n)), np.empty((len(TRUTH), n)), np.empty((3, n))
    kc = bench.kc
    closed_loop_kernel(
        np.ascontiguousarray(controller.reference(t), float),
        sig,
        constants,
        kc.scalars,
        kc.C_h,
        kc.v_h,
        kc.creep_decay,
        kc.creep_R,
        bench.state,
        bench.hp_u.b,
        bench.hp_u.a,
        bench.hp_u.zi,
        bench.hp_i.zi,
        adc,
        bench.amplifier.coefficients(),
        bench.amplifier.z,
        bench.delay.buffer,
        np.ascontiguousarray(windows._weights, float),
        tail,
        sums,
        np.ascontiguousarray(chain.gamma.coefficients, float),
        np.stack(obs.matrices),
        obs.state,
        loop,
        pending,
        measured,
        truth,
        logs,
    )
    windows._periods_done += (tail_len + n) // ns
    tail_len, sums_len, pend_len = int(loop[9]), int(loop[10]), int(loop[15])
    windows._tail = tail[:, :tail_len].copy()
    windows._period_sums = sums[:, :sums_len].copy()
    controller.u, controller.pending, controller.last_command = (
        float(loop[3]),
        pending[:pend_len].copy(),
        np.zeros(0),
    )
    chain.x_cp, chain.n, chain.masked_windows = float(loop[6]), int(loop[7]), int(loop[8])
    if n:
        obs.last_offset = float(loop[16])
    return (
        dict(zip(MEASURED, measured)),
        dict(zip(TRUTH, truth)),
        {"x_ref": logs[0], "x_hpo_rt": logs[1], "u_cmd": logs[2]},
    )
