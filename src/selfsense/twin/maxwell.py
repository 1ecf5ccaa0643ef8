"""The Maxwell resistive-capacitive hysteresis operator (thesis Eq 1.11–1.12) both twins share,
with the kernel scaffolding around it: the constants a per-sample loop needs. The safeguarded
Newton step that solves a voltage balance through the operator is the analysis's own
(:func:`selfsense.methods.hysteresis.newton_step`).

Element i holds a charge anchor q_b[i]: its voltage is (q − q_b[i])/C_h[i] clipped to ±v_h[i], and
while clipped the anchor slides with q so that the element stays at its break-away voltage. U_H(q)
is the sum over the elements, rate independent, piecewise linear and monotone in q with
|U_H| ≤ Σ v_h. The numba functions serve the twins' fast kernels; the ``*_reference`` functions,
plain numpy, serve the kernels' references, which the tests hold the fast kernels to.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numba
import numpy as np

from selfsense.twin.params import CreepParams, HysteresisParams

#: Newton iterations before a voltage balance gives up (bisection halves the bracket each time
#: Newton would leave it, so 200 reach any float's resolution)
MAX_ITERATIONS = 200


@dataclass(frozen=True)
class KernelConstants:
    """Everything a twin's per-sample loop needs, as flat arrays (numba-friendly).

    The state vector is ``head`` twin-specific values, then the Maxwell anchors q_b, then the
    creep voltages U_c.
    """

    head: int
    scalars: np.ndarray  # the twin's own scalars, in its kernel's order
    C_h: np.ndarray  # Maxwell element capacitances [F]
    v_h: np.ndarray  # Maxwell break-away voltages [V]
    creep_decay: np.ndarray  # exp(-h/τ_j) over one sample h
    creep_R: np.ndarray  # R_j = τ_j / C_j [Ω]
    rate_state: int = 0  # 1: the state holds the smoothed current (rate-dependent v_h)
    branch_state: int = 0  # 1: the state ends with the dielectric branch's voltage
    support_state: int = 0  # 2: the support mode's Tustin states, before the branch's voltage

    @classmethod
    def build(
        cls,
        head: int,
        scalars: np.ndarray,
        hysteresis: HysteresisParams,
        creep: CreepParams,
        decay: Callable[[np.ndarray], np.ndarray],
        rate_state: int = 0,
        branch_state: int = 0,
        support_state: int = 0,
    ) -> KernelConstants:
        """``decay`` maps the creep time constants τ_j [s] to their decay over one sample: each twin
        keeps the arithmetic its captures were made with."""
        C_h, v_h = hysteresis.arrays()
        tau_c = np.asarray(creep.tau, float)
        R_c = tau_c / np.asarray(creep.C, float)
        if hysteresis.R_visc > 0:  # the viscous drop is one more Voigt element (HysteresisParams)
            tau_c, R_c = np.append(tau_c, hysteresis.tau_visc), np.append(R_c, hysteresis.R_visc)
        return cls(
            head, scalars, C_h, v_h, decay(tau_c), R_c, rate_state, branch_state, support_state
        )

    @property
    def n_state(self) -> int:
        return (
            self.head
            + len(self.C_h)
            + len(self.creep_R)
            + self.rate_state
            + self.support_state
            + self.branch_state
        )

    def elements(self, state: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Views of the anchors q_b and the creep voltages U_c in ``state``."""
        nh = len(self.C_h)
        return state[self.head : self.head + nh], state[
            self.head + nh : self.head + nh + len(self.creep_R)
        ]


@numba.njit(cache=True)
def maxwell(q, q_b, C_h, v_h):
    """U_H(q) and dU_H/dq for the current anchors, without moving them."""
    u = 0.0
    slope = 0.0
    for i in range(q_b.size):
        e = (q - q_b[i]) / C_h[i]
        if e > v_h[i]:
            u += v_h[i]
        elif e < -v_h[i]:
            u -= v_h[i]
        else:
            u += e
            slope += 1.0 / C_h[i]
    return u, slope


@numba.njit(cache=True)
def slide_anchors(q, q_b, C_h, v_h):
    """Move the anchors of the elements q has driven past their break-away voltage (in place)."""
    for i in range(q_b.size):
        e = (q - q_b[i]) / C_h[i]
        if e > v_h[i]:
            q_b[i] = q - v_h[i] * C_h[i]
        elif e < -v_h[i]:
            q_b[i] = q + v_h[i] * C_h[i]


@numba.njit(cache=True)
def slide_and_sum(q, q_b, C_h, v_h):
    """:func:`slide_anchors`, then U_H(q) of :func:`maxwell` with the anchors moved, in one pass
    over the elements: an element whose anchor stays keeps the voltage just computed (the same
    division), one whose anchor slides has it computed again from the new anchor, and the sum
    runs over the elements in order, so U_H is maxwell's bit for bit at one division an element
    fewer (the kernels call it once a sample)."""
    u = 0.0
    for i in range(q_b.size):
        e = (q - q_b[i]) / C_h[i]
        if e > v_h[i]:
            q_b[i] = q - v_h[i] * C_h[i]
            e = (q - q_b[i]) / C_h[i]
        elif e < -v_h[i]:
            q_b[i] = q + v_h[i] * C_h[i]
            e = (q - q_b[i]) / C_h[i]
        if e > v_h[i]:
            u += v_h[i]
        elif e < -v_h[i]:
            u -= v_h[i]
        else:
            u += e
    return u


@numba.njit(cache=True)
def span(v_h):
    """max |U_H| = Σ v_h, which brackets a voltage balance's root."""
    vmax = 0.0
    for i in range(v_h.size):
        vmax += v_h[i]
    return vmax


@numba.njit(cache=True)
def balanced(f, target):
    """Whether a balance's residual f is zero to the resolution of its target voltage."""
    return abs(f) < 1e-13 * (1.0 + abs(target))


def maxwell_reference(q: float, q_b: np.ndarray, C_h: np.ndarray, v_h: np.ndarray) -> float:
    """Plain-numpy :func:`maxwell` (U_H only)."""
    return float(np.sum(np.clip((q - q_b) / C_h, -v_h, v_h)))


def slide_anchors_reference(q: float, q_b: np.ndarray, C_h: np.ndarray, v_h: np.ndarray) -> None:
    """Plain-numpy :func:`slide_anchors`."""
    q_b[:] = np.clip(q_b, q - v_h * C_h, q + v_h * C_h)
