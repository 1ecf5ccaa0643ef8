"""The closed loop's drive at the folded ripple frequency, and what it does to C_e (a twin study).

A verification step, like :mod:`selfsense.verify.error_budget`: it reads the twin's truth, and runs
on the twin's datasets only. In the real-time loop of Chapter 6
(:class:`selfsense.twin.closed_loop.HPOIntegralController`) the observer integrates the measured
current sample by sample, the 100 kHz ripple current folded onto fs/ns with it (part of the error
budget's "current noise"), and the integral controller, stepping every sample at ω_C (Eq 6.1–6.3),
passes part of that folded ripple on to the drive. The drive reaches the ripple channels through
their high-pass filters (:class:`selfsense.twin.instruments.HighPass`), where a component at the
folded ripple frequency cannot be told from the ripple: it moves C_e (Eq 3.12) and, through
Γ (Eq 5.4), x̂.

:func:`leak_row` measures each closed-loop capture twice: as the campaign simulated it, and
simulated again with the drive kept out of the ripple channels (the twin's what-if,
``drive_leak=False``; :func:`selfsense.twin.experiment.simulate_experiment`), everything else
equal. Per variant: the drive command's component at the folded ripple frequency against the ripple
voltage's, each over every ripple window (their median ratio); the C_e estimate's error against the
truth over the same windows; and the observer error as Table 6.2 counts it with its C_e estimate
part at that max (:func:`selfsense.verify.error_budget.capture_budget`).
"""

from __future__ import annotations

import tempfile
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path

import numpy as np

from selfsense.chapters.ch6 import settled_after
from selfsense.io.capture import open_capture
from selfsense.methods.gamma import GammaPolynomial
from selfsense.methods.observer import HPOGains
from selfsense.methods.ripple import RippleExtractor, plan_from_capture
from selfsense.twin.experiment import simulate_experiment
from selfsense.verify.error_budget import capture_budget
from selfsense.verify.truth import Truth

AS_SIMULATED = "as simulated"
NO_LEAK = "no drive leak"


def capture_leak(path: str | Path, n_periods: int, omega_c: float) -> dict[str, float]:
    """A closed-loop capture's drive at the folded ripple frequency and its C_e error, from the
    loop's settling on (Table 6.2's samples): the median over ripple windows of |u_cmd|/|Ur| at that
    frequency [%], and the C_e estimate's mean and rms error against the truth's window means [%].

    The bins are taken of the channels' first differences: a window's sums reject a constant but not
    the drive's slope, which differencing makes a constant; it scales both bins alike."""
    with open_capture(path, require=["Ur", "Ir", "u_cmd"]) as cap:
        truth = Truth.from_capture(cap, names=("C_e",))
        plan = plan_from_capture(cap, n_periods)
        first = settled_after(float(cap.attribute("warmup_s")), omega_c) * cap.fs
        ce, drive = RippleExtractor(plan), RippleExtractor(plan)
        errors, ratios, last = [], [], None
        for _, d in cap.iter_chunks(["Ur", "Ir", "u_cmd"]):
            windows = ce.process(d["Ur"], d["Ir"])
            # the same Fourier sums on (Δu_cmd, ΔUr): their folded-bin coefficients side by side
            last = (d["u_cmd"][0], d["Ur"][0]) if last is None else last
            pair = drive.process(
                np.diff(d["u_cmd"], prepend=last[0]), np.diff(d["Ur"], prepend=last[1])
            )
            last = (d["u_cmd"][-1], d["Ur"][-1])
            keep = windows.sample_index - plan.block_len + 1 >= first
            true = truth.means(windows.sample_index[keep], plan.block_len)["C_e"]
            errors.append(100 * (windows.C_e[keep] / true - 1))
            ratios.append(
                100 * np.hypot(pair.A_V, pair.B_V)[keep] / np.hypot(pair.A_I, pair.B_I)[keep]
            )
    errors, ratios = np.concatenate(errors), np.concatenate(ratios)
    if not errors.size:
        raise ValueError(f"{path}: no ripple window after the loop settles")
    return {
        "u_cmd at the folded ripple frequency [% of Ur's]": float(np.median(ratios)),
        "C_e error mean [%]": float(np.mean(errors)),
        "C_e error rms [%]": float(np.sqrt(np.mean(errors**2))),
        "windows": int(errors.size),
    }


def leak_row(
    run: str,
    captures: dict[str, str | Path],
    n_periods: int,
    gamma: GammaPolynomial,
    gains: HPOGains,
    omega_c: float,
) -> dict[str, object]:
    """Closed-loop ``run``'s row: for each variant ({variant: capture}, :data:`AS_SIMULATED` and
    :data:`NO_LEAK`), :func:`capture_leak` and the observer error Table 6.2 counts with its C_e
    estimate part at the max, in columns "<quantity>, <variant>"."""
    row: dict[str, object] = {"run": run}
    for variant, path in captures.items():
        budget = capture_budget(path, n_periods, gamma, gains, omega_c)[""]
        values = capture_leak(path, n_periods, omega_c) | {
            "max |ε_OCL| [µm]": budget["total max error [µm]"],
            "C_e estimate at ε_OCL's max [µm]": budget["C_e estimate at total max [µm]"],
        }
        row |= {f"{name}, {variant}": value for name, value in values.items()}
    return row


def leak_study(
    captures: Sequence[str | Path],
    config: Mapping,
    controller_for: Callable,
    n_periods: int,
    gamma: GammaPolynomial,
    gains: HPOGains,
    omega_c: float,
) -> list[dict[str, object]]:
    """:func:`leak_row` of each closed-loop capture (raw/<dataset>/<experiment>.nc) against the same
    experiment simulated again (``config``: the campaign and capture settings, ``controller_for``:
    :func:`selfsense.twin.closed_loop.controller_factory`'s) with the drive kept out of the ripple
    channels, into a scratch folder: the what-if captures are not the campaign's."""
    rows = []
    with tempfile.TemporaryDirectory() as scratch:
        for path in map(Path, captures):
            no_leak = Path(scratch) / path.name
            simulate_experiment(
                path.parents[1],
                path.parent.name,
                path.stem,
                config,
                no_leak,
                controller_for=controller_for,
                drive_leak=False,
            )
            rows.append(
                leak_row(
                    path.stem,
                    {AS_SIMULATED: path, NO_LEAK: no_leak},
                    n_periods,
                    gamma,
                    gains,
                    omega_c,
                )
            )
    return rows
