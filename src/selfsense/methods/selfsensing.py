"""The self-sensing chain of Fig 5.11: ripple → C_e → Γ → hybrid position observer, streamed.

One object serves the offline analysis of captures and the real-time loop inside the twin
(Chapter 6), so what the published loop used is what the pipeline analyses.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import NamedTuple

import numpy as np

from selfsense.io.capture import open_capture
from selfsense.methods.gamma import GammaPolynomial
from selfsense.methods.observer import HPOGains, HybridPositionObserver
from selfsense.methods.ripple import RippleExtractor, SamplingPlan, plan_from_capture


class LaserChunk(NamedTuple):
    """One chunk of a capture through the chain, beside the laser
    (:meth:`SelfSensingChain.against_laser`)."""

    start: int  # global index of the chunk's first sample
    t: np.ndarray  # sample times [s]
    x_laser: np.ndarray  # laser position relative to the capture's first laser sample [m]
    out: dict[str, np.ndarray]  # SelfSensingChain.process's outputs


class SelfSensingChain:
    """Per-sample position estimate from ripple voltage/current and drive current.

    x_CP = Γ(C_e) — or Γ_T(C_e, T) with the stack temperature in :attr:`temperature` [°C]
    (Eq 7.13, Chapter 7) — becomes available at the end of each ripple window and is held until
    the next one, as the real-time system holds it; a window whose C_e is not finite (a NaN burst
    in the capture) keeps the previous x_CP, so one bad window cannot poison the observer.
    """

    def __init__(
        self,
        plan: SamplingPlan,
        gamma: GammaPolynomial,
        gains: HPOGains,
        fs: float,
        method: str = "tustin",
    ):
        self.extractor = RippleExtractor(plan)
        self.gamma = gamma
        self.observer = HybridPositionObserver(gains, fs, method)
        self.x_cp = 0.0
        self.temperature = 23.0
        self.n = 0
        self.masked_windows = 0

    def process(self, ur: np.ndarray, ir: np.ndarray, current: np.ndarray) -> dict[str, np.ndarray]:
        """One chunk: returns per-sample x̂ (x_hat), held x_CP (x_cp), Î0 (i0_hat) and the current
        the observer was fed (current: NaN samples zeroed)."""
        blocks = self.extractor.process(ur, ir)
        x_cp = self.gamma.predict(blocks.C_e, self.temperature)
        good = np.isfinite(x_cp)
        self.masked_windows += int(np.count_nonzero(~good))
        ends, x_cp = blocks.sample_index[good] - self.n, x_cp[good]
        # sample j sees the latest window that ended strictly before it
        if x_cp.size:
            latest = np.searchsorted(ends, np.arange(len(ur)), side="left") - 1
            held = np.where(latest >= 0, x_cp[np.maximum(latest, 0)], self.x_cp)
            self.x_cp = float(x_cp[-1])
        else:
            held = np.full(len(ur), self.x_cp)
        current = np.where(np.isfinite(current), current, 0.0)
        x_hat, i0_hat = self.observer.step_full(current, held)
        self.n += len(ur)
        return {"x_hat": x_hat, "x_cp": held, "i0_hat": i0_hat, "current": current}

    def against_laser(
        self, chunks: Iterable[tuple[int, Mapping[str, np.ndarray]]]
    ) -> Iterable[LaserChunk]:
        """Stream a capture's ``(start, channels)`` chunks (Ur, Ir, I, x_laser) through the chain.

        The laser is taken relative to its first sample, the zero the observer starts from: every
        offline evaluation of x̂ against the laser pairs them here, so they count the same error.
        """
        x0 = None
        for start, data in chunks:
            out = self.process(data["Ur"], data["Ir"], data["I"])
            if x0 is None:
                x0 = float(data["x_laser"][0])
            x = data["x_laser"] - x0
            yield LaserChunk(start, (start + np.arange(len(x))) / self.observer.fs, x, out)


def audit_realtime(
    capture, gamma: GammaPolynomial, gains: HPOGains, n_periods: int
) -> dict[str, float]:
    """The self-sensing chain recomputed offline from a closed-loop capture's raw channels against
    the real-time estimate x̂ its loop logged: max |offline − logged| and the log's resolution
    [m]."""
    worst = 0.0
    with open_capture(capture, require=("Ur", "Ir", "I", "x_hpo_rt")) as cap:
        chain = SelfSensingChain(plan_from_capture(cap, n_periods), gamma, gains, cap.fs)
        for _, d in cap.iter_chunks(("Ur", "Ir", "I", "x_hpo_rt")):
            offline = chain.process(d["Ur"], d["Ir"], d["I"])["x_hat"]
            worst = max(worst, float(np.max(np.abs(offline - d["x_hpo_rt"]))))
        return {"max |offline − logged|": worst, "log resolution": cap.resolution("x_hpo_rt")}
