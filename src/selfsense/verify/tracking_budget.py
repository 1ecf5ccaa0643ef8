"""Chapter 6's tracking error split into its sources with the twin's truth (a verification step).

The companion of :mod:`selfsense.verify.error_budget`, which splits the observer's error: it needs a
simulated capture's ``/truth`` group, so it runs on the twin's datasets only. The tracking error
of Tables 6.1–6.2, ε_T = x_R − x_laser (:func:`selfsense.chapters.ch6.errors`), is taken on the same
means over each folded ripple period (the real-time loop's 4 kHz rate) of the same run, with the
laser zeroed at its first mean (:func:`selfsense.chapters.ch6.load_run`), and split at truth signals
so that the parts add up to it exactly, mean by mean.

Open loop, where the drive is Chapter 6's feedforward U = x_R·k/α, by the voltage balance
U = U_P + U_H + ΣU_c (Eq 1.6) and the stack's static mechanics k x = α U_P (Eq 1.4):

    ε_TOL = [x_R − (α/k)·U] + (α/k)·U_H + (α/k)·(U − U_P − U_H) + [(α/k)·U_P − x] + [x − x_laser]
            feedforward      hysteresis   creep                   stack dynamics     laser

Closed loop, with the estimate x̂ the loop logged (channel ``x_hpo_rt``):

    ε_TCL = [x_R − x̂] + [x̂ − x] + [x − x_laser]
            controller   observer   laser

* ``feedforward``: what the drive U misses of x_R through the twin's own α/k (the drive's hold
  between loop updates and its quantisation; a gain error would land here);
* ``hysteresis``, ``creep``: the Maxwell operator's voltage (Eq 1.11–1.12) and the creep elements',
  each as the position it takes from U_P;
* ``stack dynamics``: inertia and damping, (m ẍ + b ẋ)/k, and any load force;
* ``controller``: ε_CCL, the loop's error against its own estimate (Eq 6.1–6.3);
* ``observer``: the estimate's error against the true position (its own sources are the observer's
  budget's);
* ``laser``: the laser's resolution, its drift and the zero it is read from.

The controller's own error ε_CCL = x_R − x̂ (Table 6.2) is split further, through the loop that
made it. The loop integrates ε_CCL per sample, each sample of a block applying the error of the same
sample of the block before (:class:`selfsense.twin.closed_loop.HPOIntegralController`), so that
over the means, for an error constant within a block,

    (α/k)(ū_k − ū_(k−1)) = (ω_C/fs)·[(ns + 1)/2·ε_(k−1) + (ns − 1)/2·ε_(k−2)],

and with x̂ = (α/k)·u_cmd + d, where d is everything the quasi-static plant (Eq 6.3's α/k) does not
explain, ε_CCL = S·(x_R − d), S(z) = (1 − z⁻¹)/(1 − z⁻¹ + h₁z⁻¹ + h₂z⁻²) the loop's sensitivity at
the means' rate (:func:`loop_sensitivity`). Splitting d at the truth as the open loop's
ε_TOL is split:

    ε_CCL = S·x_R + S·(α/k)U_H + S·(α/k)(U − U_P − U_H) − S·[x − (α/k)U_P]
            loop lag  hysteresis   creep                  stack dynamics
          − S·[x̂ − x] − S·(α/k)(U − u_cmd) + r
            observer     drive             loop model

* ``loop lag``: what the linear Type-I loop with its one-block delay leaves of the reference, the
  error a hysteresis-free stack and a perfect observer would still have (|1 − T| of
  :func:`selfsense.methods.control.tracking_prediction`, with the delay);
* ``hysteresis``, ``creep``, ``stack dynamics``: the plant's departures from α/k, as the loop
  rejects them;
* ``observer``: the estimate's error, which the loop follows inside its bandwidth;
* ``drive``: the amplifier's departure from the command (none in the twin but the logged
  command's quantisation);
* ``loop model``: r, what the means-rate model of the per-sample loop misses (an error that varies
  within a block; the engagement's first block).

The truth is stored every ``decimation``-th sample; each mean's truth is the mean of the 4-point
cubic (:meth:`selfsense.verify.truth.Truth.means`) over the mean's samples. That is exact for the
smooth P2 profiles, not for what happens between two stored values: P1's voltage steps and the
bench's 2.5 kHz mode they ring, above the stored rate's 2 kHz Nyquist frequency. In the means next
to a step the interpolated U, U_P and x are off, and feedforward, stack dynamics and laser take
errors that cancel in their sum (the sources still add up to ε_T exactly).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from scipy.signal import lfilter

from selfsense.chapters.ch6 import load_run, segment_windows, settled_after
from selfsense.io.capture import open_capture
from selfsense.methods.ripple import plan_from_capture
from selfsense.verify.error_budget import SpanBudgets
from selfsense.verify.truth import Truth

OPEN_SOURCES = ("feedforward", "hysteresis", "creep", "stack dynamics", "laser")
CLOSED_SOURCES = ("controller", "observer", "laser")
CONTROLLER_SOURCES = (
    "loop lag",
    "hysteresis",
    "creep",
    "stack dynamics",
    "observer",
    "drive",
    "loop model",
)

#: the /truth states the budget reads
TRUTH_STATES = ("x", "U_P", "U_H", "U_drive")


def split(
    run: Mapping[str, np.ndarray], true: Mapping[str, np.ndarray], alpha_over_k: float, closed: bool
) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """ε_T = x_R − x_laser of one run's means and its sources (module docstring), in metres."""
    x_ref, x_laser, x = run["x_ref"], run["x_laser"], true["x"]
    total = x_ref - x_laser
    if closed:
        x_hat = run["x_hat"]
        return total, {"controller": x_ref - x_hat, "observer": x_hat - x, "laser": x - x_laser}
    U, U_P, U_H = true["U_drive"], true["U_P"], true["U_H"]
    return total, {
        "feedforward": x_ref - alpha_over_k * U,
        "hysteresis": alpha_over_k * U_H,
        "creep": alpha_over_k * (U - U_P - U_H),
        "stack dynamics": alpha_over_k * U_P - x,
        "laser": x - x_laser,
    }


def loop_sensitivity(omega_c: float, fs: float, ns: int) -> tuple[np.ndarray, np.ndarray]:
    """S(z) = ε_CCL/(x_R − d) of the real-time loop at the rate of its blocks' means (module
    docstring): (b, a) for :func:`scipy.signal.lfilter`."""
    h = omega_c / fs
    return np.array([1.0, -1.0]), np.array([1.0, h * (ns + 1) / 2 - 1.0, h * (ns - 1) / 2])


def controller_split(
    run: Mapping[str, np.ndarray],
    true: Mapping[str, np.ndarray],
    alpha_over_k: float,
    sensitivity: tuple[np.ndarray, np.ndarray],
    engaged: np.ndarray,
) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """ε_CCL = x_R − x̂ of one closed-loop run's means and its sources (module docstring), in metres;
    the loop's filter starts from rest at the first ``engaged`` mean, as the loop does (0
    before)."""
    x_hat, x, U = run["x_hat"], true["x"], true["U_drive"]
    drives = {
        "loop lag": run["x_ref"],
        "hysteresis": alpha_over_k * true["U_H"],
        "creep": alpha_over_k * (U - true["U_P"] - true["U_H"]),
        "stack dynamics": alpha_over_k * true["U_P"] - x,
        "observer": x - x_hat,
        "drive": alpha_over_k * (run["u_cmd"] - U),
    }
    total = run["x_ref"] - x_hat
    parts = {
        name: np.where(engaged, lfilter(*sensitivity, np.where(engaged, v, 0.0)), 0.0)
        for name, v in drives.items()
    }
    parts["loop model"] = total - sum(parts.values())
    return total, parts


def capture_tracking_budget(
    path, protocol: Mapping, closed: bool, omega_c: float, per_segment: bool
) -> dict[str, dict[str, dict[str, float]]]:
    """One Chapter 6 run's tracking budget, counted as its table counts: P1 (``per_segment``) per
    segment a–h over the steady windows of :func:`selfsense.chapters.ch6.segment_windows` (Table
    6.1), a P2 profile from the loop's settling on (:func:`selfsense.chapters.ch6.settled_after`,
    Table 6.2). Returns {"tracking": {segment or "":
    :meth:`selfsense.verify.error_budget.BudgetStats.row`}} and, in closed loop, "controller": the
    same of ε_CCL's split (:func:`controller_split`)."""
    run = load_run(path, protocol, command=closed)
    if closed and (run["x_hat"] is None or run["u_cmd"] is None):
        raise ValueError(
            f"{path}: a closed-loop run without the logged estimate x_hpo_rt and command u_cmd"
        )
    with open_capture(path, require=("U", "x_laser")) as cap:
        attrs, states = cap.read_truth()
        truth = Truth.from_group(attrs, states, cap.length(), str(path), names=TRUTH_STATES)
        fs, ns = cap.fs, plan_from_capture(cap, 1).ns
    last = np.rint(run["t"] * fs + (ns - 1) / 2).astype(np.int64)
    true, alpha_over_k = (
        truth.means(last, ns),
        float(attrs["stack_alpha"]) / float(attrs["stack_k"]),
    )
    warmup = float(protocol.get("warmup", 0.0))
    if per_segment:
        spans = segment_windows(protocol, omega_c)
    else:
        spans = [("", settled_after(warmup, omega_c), np.inf)]
    splits = {
        "tracking": (
            CLOSED_SOURCES if closed else OPEN_SOURCES,
            split(run, true, alpha_over_k, closed),
        )
    }
    if closed:
        engaged = (
            last - (ns - 1) >= warmup * fs
        )  # the loop engages at the warm-up's end (realtime_controller)
        splits["controller"] = (
            CONTROLLER_SOURCES,
            controller_split(run, true, alpha_over_k, loop_sensitivity(omega_c, fs, ns), engaged),
        )
    out = {}
    for name, (sources, (total, parts)) in splits.items():
        stats = SpanBudgets(spans, sources)
        stats.add(run["t"], total, parts)
        out[name] = stats.rows()
    return out
