"""The bench's real-time loop (thesis Chapter 6): the self-sensing chain of
:mod:`selfsense.methods.selfsensing` feeds the integral controller of
:mod:`selfsense.methods.control`, stepped inside the twin block by block — the same objects the
offline analysis runs over the captures. :func:`simulate_closed_loop` runs a closed-loop experiment
of the catalogue with the loop configured from the identified values.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from selfsense.methods.control import IntegralController
from selfsense.methods.electromech import load_k_over_alpha
from selfsense.methods.gamma import GammaPolynomial, load_gamma
from selfsense.methods.observer import HPOGains, load_gains
from selfsense.methods.ripple import SamplingPlan
from selfsense.methods.selfsensing import SelfSensingChain
from selfsense.twin.experiment import simulate_experiment

if TYPE_CHECKING:
    from selfsense.io.capture import ScanReport
    from selfsense.methods.drive import Drive
    from selfsense.twin.bench import DaqPlan

LOG = logging.getLogger("selfsense.twin")


class HPOIntegralController:
    """The bench's real-time loop: self-sensing chain → integral controller → drive voltage.

    Implements the twin's ``Controller`` hook. The loop stays open (U = 0) until ``engage_at``
    while the observer learns the current offset. Afterwards the integrator advances sample by
    sample on the errors of the block before (one block of delay, as a DAQ loop that computes
    a block while the next is played). Integrating per sample rather than stepping U once per
    block matters: a staircase at the block rate (fs/ns) would put its edges right on the folded
    ripple frequency, through the ripple high-pass filters, and corrupt C_e.
    """

    logs = ("x_ref", "x_hpo_rt", "u_cmd")

    def __init__(
        self,
        chain: SelfSensingChain,
        gains: IntegralController,
        reference: Callable[[np.ndarray], np.ndarray],
        fs: float,
        block_len: int,
        engage_at: float,
        u_limits: tuple[float, float] = (-20.0, 120.0),
        compiled: bool = False,
    ):
        self.compiled = compiled  # the twin runs the engaged samples through run_blocks
        self.chain = chain
        self.gains = gains
        self.reference = reference
        self.fs = fs
        self.block_len = block_len
        self.engage_at = engage_at
        self.u_limits = u_limits
        self.u = 0.0
        self.pending = np.zeros(0)  # integrator increments from the last observed block
        self.last_command = np.zeros(0)

    def command(self, t: np.ndarray) -> np.ndarray:
        steps = np.zeros(len(t))
        n = min(len(t), len(self.pending))
        steps[:n] = self.pending[:n]
        # the integrator stops at the amplifier's limits (anti-windup)
        u = np.clip(self.u + np.cumsum(steps), *self.u_limits)
        self.u = float(u[-1]) if len(u) else self.u
        self.pending = np.zeros(0)
        self.last_command = u
        return u

    def run_blocks(self, bench, t: np.ndarray, signals: Mapping[str, np.ndarray]):
        """The engaged samples t of a chunk, block by block as :meth:`command` and :meth:`observe`
        step them, in one numba loop with the bench (:func:`selfsense.twin.realtime.run_blocks`)."""
        from selfsense.twin.realtime import run_blocks

        return run_blocks(bench, self, t, signals)

    def observe(self, t: np.ndarray, measured: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
        x_hat = self.chain.process(measured["Ur"], measured["Ir"], measured["I"])["x_hat"]
        engaged = t >= self.engage_at
        x_ref = np.where(engaged, self.reference(t), 0.0)
        self.pending = np.where(engaged, self.gains.K_I * (x_ref - x_hat) / self.fs, 0.0)
        # the idle warm-up is observed in one stretch with no command: the loop applied 0 V
        u_cmd = self.last_command if len(self.last_command) == len(t) else np.zeros(len(t))
        self.last_command = np.zeros(0)
        return {"x_ref": x_ref, "x_hpo_rt": x_hat, "u_cmd": u_cmd}


def controller_factory(
    n_periods: int, gamma: GammaPolynomial, observer: HPOGains, controller: IntegralController
):
    """``controller_for`` of :func:`selfsense.twin.experiment.simulate_experiment`: each
    closed-loop run's :func:`realtime_controller` with these identified values."""
    return lambda daq, drive, warmup: realtime_controller(
        daq, drive, warmup, n_periods, gamma, observer, controller
    )


def realtime_controller(
    daq: DaqPlan,
    drive: Drive,
    warmup: float,
    n_periods: int,
    gamma: GammaPolynomial,
    observer: HPOGains,
    controller: IntegralController,
    compiled: bool = True,
) -> HPOIntegralController:
    """The bench's real-time loop (Chapter 6) configured as the bench's was: the identified Γ and
    observer gains (a0, ω_S, ζ_S) estimate x̂, ``controller`` (ω_C, k/α) drives the stack from it.
    ``compiled=False``: the Python reference, stepped block by block."""
    plan = SamplingPlan(daq.fr_nominal, daq.ns, daq.nf, n_periods)
    chain = SelfSensingChain(plan, gamma, observer, daq.fs)
    return HPOIntegralController(
        chain, controller, drive, daq.fs, plan.ns, warmup, compiled=compiled
    )


def simulate_closed_loop(
    raw_dir: str | Path,
    dataset: str,
    experiment: str,
    config: Mapping,
    gamma: str | Path,
    observer: str | Path,
    model: str | Path,
    output: str | Path | None = None,
) -> ScanReport:
    """A closed-loop experiment of the catalogue (Chapter 6) on the twin, its real-time loop
    (:func:`realtime_controller`) configured as the bench's was: with the Γ (Eq 5.4, Table 5.2) and
    observer gains (a0, ω_S, ζ_S; Table 5.3) the Chapter 5 stages wrote to ``gamma`` and
    ``observer``, and K_I = ω_C·k/α (Eq 6.3) with k/α from the Chapter 4 identification's
    ``model``. Writes the capture (:func:`selfsense.twin.experiment.simulate_experiment`) and
    returns its QC scan; logs the K_I's k/α and the a0 it ran with.

    ``config``: the experiment's "campaign" and "capture" settings (as ``simulate_experiment``
    takes them), the loop's crossover "omega_c" [rad/s] and the ripple windows' "n_periods"."""
    gains = load_gains(observer)
    loop = IntegralController(config["omega_c"], load_k_over_alpha(model))
    scan = simulate_experiment(
        raw_dir,
        dataset,
        experiment,
        {"campaign": config["campaign"], "capture": config["capture"]},
        output,
        controller_for=controller_factory(config["n_periods"], load_gamma(gamma), gains, loop),
    )
    LOG.info(
        "wrote %s with K_I from k/α = %.4g V/m, a0 = %.4g C/m",
        scan.path,
        loop.k_over_alpha,
        gains.a0,
    )
    return scan
