"""The twin's variants: mechanisms of the bench that today's twin leaves out, each a switchable
term whose parameters (a manifest's ``twin.<variant>``, :data:`.params.VARIANTS`) are off by
default, so that a manifest without them makes today's captures bit for bit (docs/twin.md,
"Variants"). Each is a pure function, or a small per-sample stage in numba with its numpy
reference, which the tests hold it to and to the term's closed form.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from selfsense.twin.params import PowerAmplifierParams

#: the E-617's output range [V]: its −2…12 V input at gain 10 (E-617 user manual PZ201E, p. 13)
E617_OUTPUT = (-20.0, 120.0)


def series_load(k_load: float, compliance: float) -> float:
    """The stiffness a load k_load presents through a compliance c in series with it:
    1/(1/k_load + c). No load (0) or no compliance leaves k_load as it is, the same float."""
    if k_load == 0.0 or compliance == 0.0:
        return k_load
    return 1.0 / (1.0 / k_load + compliance)


class PowerAmplifier:
    """The PI E-617.00F from command to stack (:class:`.params.PowerAmplifierParams`): the command
    clipped to the output range, a first-order stage of time constant τ, exact for a command held
    over the sample before (U_n = U_{n−1} + (1 − e^{−h/τ})(u_n − U_{n−1})), and its step limited
    to the slew its current limit allows, |U_n − U_{n−1}| ≤ h/slew_time (dU/dt ≤ I_max/C_load).
    A step into the stack is a ramp of slope I_max/C_load, then first-order settling. The output
    U_{n−1} is its state, carried across chunks (0 V before a run). The same interface as
    :class:`.instruments.Amplifier`, which it replaces when on.
    """

    def __init__(self, p: PowerAmplifierParams, fs: float):
        h = 1.0 / fs
        gain = 1.0 - math.exp(-h / p.time_constant) if p.time_constant > 0 else 1.0
        max_step = h / p.slew_time if p.slew_time > 0 else math.inf
        self.stage = np.array([gain, max_step, *E617_OUTPUT])
        self.z = np.zeros(1)

    def __call__(self, command: np.ndarray, compiled: bool = True) -> np.ndarray:
        """The voltage at the stack for ``command``; ``compiled=False``: by the numpy reference."""
        command = np.ascontiguousarray(command, dtype=float)
        out = np.empty(len(command))
        if compiled:
            rate_limited(command, self.stage, self.z, out)
        else:
            rate_limited_reference(command, self.stage, self.z, out)
        return out

    def coefficients(self) -> np.ndarray:
        """The compiled closed loop's copy: :meth:`.instruments.Amplifier.coefficients`' layout,
        [ideal, b0, b1, a0, a1], then [rate limited, gain, max step, low, high]."""
        return np.array([0.0, 0.0, 0.0, 0.0, 0.0, 1.0, *self.stage])


@numba.njit(cache=True)
def rate_limited(u, stage, z, out):
    """:class:`PowerAmplifier`'s stage over u into out: stage = [gain, max step, low, high], z[0]
    the output before u[0] (updated)."""
    gain, max_step, lo, hi = stage[0], stage[1], stage[2], stage[3]
    y = z[0]
    for n in range(u.size):
        step = gain * (min(max(u[n], lo), hi) - y)
        y = y + min(max(step, -max_step), max_step)
        out[n] = y
    z[0] = y


def rate_limited_reference(u, stage, z, out) -> None:
    """The numpy reference of :func:`rate_limited` (a recursion: one sample at a time)."""
    gain, max_step, lo, hi = stage
    y = z[0]
    for n, command in enumerate(u):
        y = y + np.clip(gain * (np.clip(command, lo, hi) - y), -max_step, max_step)
        out[n] = y
    z[0] = y


class Delay:
    """The DAQ's output latency of d samples (:class:`.params.LoopParams`): the command of sample n
    reaches the amplifier at sample n + d, a pure delay T = d/fs whose phase lag at ω is ωT. The
    d commands in flight are its state, carried across chunks (0 V before a run)."""

    def __init__(self, samples: int):
        self.buffer = np.zeros(samples)

    def __call__(self, command: np.ndarray, compiled: bool = True) -> np.ndarray:
        """The delayed command (the same array when d = 0); ``compiled=False``: the numpy
        reference."""
        if not len(self.buffer):
            return command
        command = np.ascontiguousarray(command, dtype=float)
        out = np.empty(len(command))
        (delay_run if compiled else delay_reference)(command, self.buffer, out)
        return out


@numba.njit(cache=True)
def delay_run(u, buffer, out):
    """:class:`Delay` over u into out; buffer: the commands in flight, oldest first (updated)."""
    d = buffer.size
    for n in range(u.size):
        out[n] = buffer[0]
        for i in range(d - 1):
            buffer[i] = buffer[i + 1]
        buffer[d - 1] = u[n]


def delay_reference(u, buffer, out) -> None:
    """The numpy reference of :func:`delay_run`: the commands in flight, then u, shifted by d."""
    line = np.concatenate([buffer, u])
    out[:] = line[: len(u)]
    buffer[:] = line[len(u) :]
