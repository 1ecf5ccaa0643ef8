"""The twin's own feedforward: the voltage its rate-independent model needs for a position, against
which an identified Maxwell model (:mod:`selfsense.methods.hysteresis`) is judged.

Quasi-statically the stack's mechanics give U_P = k·x/α (Eq 4.2 without force or motion), its
electrics q = C_P·U_P + α·x with C_P = C_P0 + ΔCx·x at T_ref (Eq 4.4–4.5), and the drive holds
U = U_P + U_H(q) (Eq 1.11–1.12) with the twin's own Maxwell elements, anchored at q = 0 as the
twin starts. What the twin adds beyond that (creep, the viscous drop, the bench's dynamics) is
outside any rate-independent inverse, the twin's as much as an identified one.
"""

from __future__ import annotations

import numpy as np

from selfsense.methods.hysteresis import element_strains
from selfsense.twin.params import TwinParams


def twin_voltage(params: TwinParams, x: np.ndarray) -> np.ndarray:
    """U [V] the twin's rate-independent model gives for the positions x [m] of a record that
    starts at rest (q = 0)."""
    s = params.stack
    x = np.asarray(x, float)
    u_p = s.k * x / s.alpha
    q = (s.C_P0 + s.dC_x * x) * u_p + s.alpha * x
    C_h, v_h = params.hysteresis.arrays()
    # element i's voltage is its charge strain over C_h, clipped at v_h: a strain clipped at v_h·C_h
    strains = element_strains(np.r_[0.0, q], v_h * C_h)[1:]
    return u_p + strains @ (1.0 / C_h)
