"""Sensorless closed-loop control with HPO feedback (thesis Chapter 6, Eq 6.1–6.3).

An integral controller u = K_I ∫(x_R − x̂) dt with K_I = ω_C·k/α closes a Type-I loop with
crossover ω_C around the stack (x ≈ (α/k) U at these frequencies). The bench's real-time loop that
steps it inside the twin is :mod:`selfsense.twin.closed_loop`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

if (
    TYPE_CHECKING
):  # pandas and python-control where used: ≈ 0.7 s of a closed-loop simulation's start-up
    import control as ct
    import pandas as pd


@dataclass(frozen=True)
class IntegralController:
    """Gains of the integral loop (Eq 6.1–6.3)."""

    omega_c: float  # crossover [rad/s], thesis 2π·250
    k_over_alpha: float  # [V/m] from the identification

    @property
    def K_I(self) -> float:
        """K_I = ω_C·k/α [V/(m s)] (Eq 6.3)."""
        return self.omega_c * self.k_over_alpha

    def loop(self) -> ct.TransferFunction:
        """Open loop L(s) = K_I/s · α/k = ω_C/s (quasi-static plant)."""
        # here, not at the top: ≈ 0.4 s per closed-loop simulation job otherwise
        import control as ct

        return ct.tf([self.K_I / self.k_over_alpha], [1, 0])

    def tracking(self) -> ct.TransferFunction:
        """Closed-loop x/x_R = ω_C/(s + ω_C)."""
        import control as ct

        return ct.feedback(self.loop(), 1)


def tracking_prediction(
    gains: IntegralController, frequencies_hz, amplitude: float
) -> pd.DataFrame:
    """Predicted tracking error amplitude |1 − T(jω)|·A and phase lag of T, per frequency.

    Explains why the loop tracks at 10 Hz and loses the 125 Hz profile: the Type-I loop's
    error grows like ω/ω_C and the lag like atan(ω/ω_C).
    """
    import pandas as pd

    T = gains.tracking()
    rows = []
    for f in frequencies_hz:
        h = complex(T(2j * np.pi * f))
        rows.append(
            {
                "frequency [Hz]": f,
                "|T|": abs(h),
                "phase lag [deg]": -np.degrees(np.angle(h)),
                "predicted error amplitude [µm]": abs(1 - h) * amplitude * 1e6,
            }
        )
    return pd.DataFrame(rows)
