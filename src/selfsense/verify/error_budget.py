"""The observer's error budget: its error against the laser split into sources with the twin's
truth.

A verification step, like :mod:`selfsense.verify.recovery`: it needs a simulated capture's
``/truth`` group (noiseless x, q, C_e and the probe offset I_0), so it runs on the twin's datasets
only.

Why the error splits exactly
----------------------------
The hybrid position observer (Fig 5.9) is linear in its two inputs, the measured current I and
the held capacitance estimate x_CP = Γ(C_e) (Eq 5.4). With x_I = ∫I dt / a0 (Eq 5.3, the
trapezoidal sum in the Tustin discretisation) it is the complementary pair of Eq 5.6 and 5.8,
x̂ = H_I·x_I + H_CP·x_CP with H_I + H_CP = 1 (the bilinear map keeps the identity in z). For any
true position x, then, H_I·x + H_CP·x = x, and the error against the laser (Table 5.4) is

    x̂ − x_laser = H_I·(x_I − x) + H_CP·(x_CP − x) − (x_laser − x).

Each difference is split once more at a truth signal, giving the six sources of :data:`SOURCES`
(signed, in metres, their sum the error sample by sample):

* ``probe offset``  H_I·(∫I_0 dt / a0) = (x̂/I_0)·I_0 (Eq 5.7): the true probe offset I_0 and its
  drift, as far as the offset estimator Î_0 (Eq 5.5) has not yet absorbed it;
* ``current noise`` H_I·(∫(I − I_0) dt / a0 − q/a0): everything else in the measured current that
  is not the stack's charge — the probe's resolution, the 100 kHz ripple current (folded onto
  fs/ns), ADC quantisation — and the trapezoidal rule's error against the true charge q;
* ``q–x map``       H_I·(q/a0 − x): the q–x hysteresis and the error of the identified a0;
* ``C_e estimate``  H_CP·(Γ(Ĉ_e) − Γ(C_e)): the ripple estimator's noise, its window and hold lag
  (Eq 3.6–3.13) and any bias against the true small-signal capacitance C_e, through Γ;
* ``Γ map``         H_CP·(Γ(C_e) − x): the fit error of Γ (Eq 5.4) and the C_e–x hysteresis;
* ``laser``         −(x_laser − x): the laser's resolution, its drift and the zero it is read from
  (its first sample, as Table 5.4 reads it).

Each term is the library's own streaming observer (:class:`HybridPositionObserver`, same gains,
rate and discretisation as the chain's) run on that term's difference signal from a zero state;
H_I·s is run as s − H_CP·s. The parts add up to the chain's error by linearity alone: rounding
aside, the sum is exact whatever the truth, while which part a given effect lands in depends on
the truth being right. The truth is stored every ``decimation``-th sample; it is interpolated to
each sample by a 4-point cubic (:meth:`Truth.at`).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from selfsense.chapters.ch5 import creep_phases, offset_compensated_charge
from selfsense.chapters.ch6 import segment_windows, settled_after
from selfsense.io.capture import open_capture, read_series
from selfsense.methods.gamma import GammaPolynomial
from selfsense.methods.observer import HPOGains, HybridPositionObserver
from selfsense.methods.ripple import SamplingPlan, WindowMeans, plan_from_capture
from selfsense.methods.selfsensing import SelfSensingChain
from selfsense.verify.truth import Truth

#: a source's value at the instant of the error's max
AT_MAX = " at total max [µm]"
#: a source's σ over P1's tests of its value at each test's max (error_budget.spread_over_spans)
AT_MAX_SPREAD = " at max σ over tests [µm]"

#: the sources of the error, in the order of the docstring (current path, then capacitance path)
SOURCES = ("probe offset", "current noise", "q–x map", "C_e estimate", "Γ map", "laser")


class Superposition:
    """The observer run once per source on that source's difference signal (module docstring).

    Every path is a :class:`HybridPositionObserver` with ``observer``'s gains, rate and
    discretisation, starting from the zero state the chain's observer starts from, so that the
    paths add up to the chain's x̂ by linearity. State carries from chunk to chunk.
    """

    def __init__(self, observer: HybridPositionObserver):
        self._paths = {
            name: HybridPositionObserver(observer.gains, observer.fs, observer.method)
            for name in SOURCES[:5]
        }

    def split(
        self,
        current: np.ndarray,
        x_cp: np.ndarray,
        x_laser: np.ndarray,
        x: np.ndarray,
        x_charge: np.ndarray,
        x_capacitance: np.ndarray,
        offset: np.ndarray,
    ) -> dict[str, np.ndarray]:
        """One chunk's sources [m]: ``current`` [A] and ``x_cp`` [m] as the chain fed its observer,
        ``x_laser`` as Table 5.4 reads it; the truth: position ``x``, q/a0 (``x_charge``), Γ(C_e)
        (``x_capacitance``) and the probe offset I_0 (``offset``, A)."""
        zero = np.zeros_like(x)
        charge = x_charge - x
        return {
            "probe offset": self._paths["probe offset"].step(offset, zero),
            # x̂(I − I_0, q/a0) − q/a0 = H_I·(x_I − x_I0 − q/a0)
            "current noise": self._paths["current noise"].step(current - offset, x_charge)
            - x_charge,
            "q–x map": charge - self._paths["q–x map"].step(zero, charge),
            "C_e estimate": self._paths["C_e estimate"].step(zero, x_cp - x_capacitance),
            "Γ map": self._paths["Γ map"].step(zero, x_capacitance - x),
            "laser": x - x_laser,
        }


@dataclass
class BudgetStats:
    """Streaming statistics of an error and its ``sources`` over the samples counted (Table 5.4's
    for the observer's; :mod:`selfsense.verify.tracking_budget` counts Chapter 6's tracking
    error)."""

    sources: tuple[str, ...] = SOURCES
    n: int = 0
    total_sq: float = 0.0
    total_max: float = 0.0
    total_at_max: float = 0.0
    time_of_max: float = float("nan")
    closure: float = 0.0
    sq: dict[str, float] = field(init=False)
    peak: dict[str, float] = field(init=False)
    at_max: dict[str, float] = field(init=False)

    def __post_init__(self) -> None:
        self.sq, self.peak = dict.fromkeys(self.sources, 0.0), dict.fromkeys(self.sources, 0.0)
        self.at_max = dict.fromkeys(self.sources, float("nan"))

    def add(
        self, t: np.ndarray, total: np.ndarray, parts: Mapping[str, np.ndarray], counted: np.ndarray
    ) -> None:
        """One chunk: ``total`` the error (x̂ − x_laser for the observer), its ``parts``, ``counted``
        the samples that count."""
        keep = counted & np.isfinite(total)  # a NaN laser sample counts nowhere, as in Table 5.4
        if not keep.any():
            return
        e, p = total[keep], {s: parts[s][keep] for s in self.sources}
        self.n += e.size
        self.total_sq += float(np.sum(e * e))
        self.closure = max(self.closure, float(np.max(np.abs(sum(p.values()) - e))))
        for s in self.sources:
            self.sq[s] += float(np.sum(p[s] * p[s]))
            self.peak[s] = max(self.peak[s], float(np.max(np.abs(p[s]))))
        k = int(np.argmax(np.abs(e)))
        if abs(e[k]) > self.total_max:
            self.total_max, self.total_at_max, self.time_of_max = (
                float(abs(e[k])),
                float(e[k]),
                float(t[keep][k]),
            )
            self.at_max = {s: float(p[s][k]) for s in self.sources}

    def row(self) -> dict[str, float]:
        """The run's budget in µm (shares of the error's mean square, with the cross terms between
        sources, which make the shares add up to 1)."""
        um, n, ms = 1e6, max(self.n, 1), self.total_sq / max(self.n, 1)
        share = {s: self.sq[s] / n / ms if ms > 0 else float("nan") for s in self.sources}
        row = {
            "total max error [µm]": self.total_max * um,
            "total rms [µm]": np.sqrt(ms) * um,
            "total at max [µm]": self.total_at_max * um,
            "time of max [s]": self.time_of_max,
        }
        for s in self.sources:
            row |= {
                f"{s} rms [µm]": np.sqrt(self.sq[s] / n) * um,
                f"{s} max [µm]": self.peak[s] * um,
                f"{s}{AT_MAX}": self.at_max[s] * um,
                f"{s} share of mean square": share[s],
            }
        return row | {
            "cross terms share of mean square": 1.0 - sum(share.values()),
            "max |sum of sources − total| [µm]": self.closure * um,
            "samples": self.n,
        }


def run_budget(
    chunks: Iterable[tuple[int, Mapping[str, np.ndarray]]],
    plan: SamplingPlan,
    gamma: GammaPolynomial,
    gains: HPOGains,
    fs: float,
    settle_s: float,
    truth: Truth,
    loop_rate: SamplingPlan | None = None,
    windows: Sequence[tuple[str, float, float]] = (),
) -> dict[str, dict[str, float]]:
    """One capture's error budget: the self-sensing chain streamed as for Table 5.4 (same chain,
    same laser zero, samples after the warm-up ``settle_s``), each chunk split into its sources.

    With ``loop_rate`` (a one-period plan), the error and its sources are counted as Table 6.2
    counts them instead: means over each folded ripple period (the real-time loop's rate,
    :func:`selfsense.chapters.ch6.load_run`), the laser zeroed at its first mean. Means are linear,
    so the sources still add up to the error.

    With ``windows`` ((label, start, end) [s], as :func:`selfsense.chapters.ch6.segment_windows`),
    one budget per label over the samples inside its windows instead (Table 6.1's segments).

    Returns :meth:`SpanBudgets.rows` ({"": row} without windows); "total max error [µm]"
    is Table 5.4's "max error [µm]" (with ``loop_rate``, Table 6.2's max |ε_O|, or Table 6.1's
    largest max |ε_OCL| of each segment).
    """
    chain = SelfSensingChain(plan, gamma, gains, fs)
    spans = windows or [("", settle_s, np.inf)]
    paths, stats = Superposition(chain.observer), SpanBudgets(spans)
    means = None if loop_rate is None else WindowMeans(loop_rate, 2 + len(SOURCES))
    zero = None
    for start, t, x_laser, out in chain.against_laser(chunks):
        true = truth.at(start + np.arange(len(t)))
        parts = paths.split(
            out["current"],
            out["x_cp"],
            x_laser,
            true["x"],
            true["q"] / gains.a0,
            chain.gamma.predict(true["C_e"], chain.temperature),
            true["I_offset"],
        )
        total = out["x_hat"] - x_laser
        if means is not None:
            index, m = means.process(x_laser, total, *(parts[s] for s in SOURCES))
            if not index.size:
                continue
            zero = m[0][0] if zero is None else zero  # the laser's first mean is Table 6.2's zero
            t, total = (index - (loop_rate.ns - 1) / 2) / fs, m[1] + zero
            parts = dict(zip(SOURCES, m[2:])) | {"laser": m[2 + SOURCES.index("laser")] + zero}
        stats.add(t, total, parts)
    return stats.rows()


class SpanBudgets:
    """One :class:`BudgetStats` per label over that label's spans ((label, start, end) [s]; a label
    may have many, as P1's segments do, one per test) and, where a label has several, one per span:
    Table 6.1's σ is the spread over the tests of each test's max, which :meth:`rows` splits too."""

    def __init__(
        self, spans: Sequence[tuple[str, float, float]], sources: tuple[str, ...] = SOURCES
    ):
        self.spans = list(spans)
        self.labels = {label: BudgetStats(sources) for label, _, _ in self.spans}
        self.each = [BudgetStats(sources) for _ in self.spans]

    def add(self, t: np.ndarray, total: np.ndarray, parts: Mapping[str, np.ndarray]) -> None:
        """One chunk of the error ``total`` and its ``parts`` at times ``t`` [s]."""
        counted = dict.fromkeys(self.labels, False)
        for (label, begin, end), one in zip(self.spans, self.each):
            if t.size and (t[0] >= end or t[-1] < begin):
                continue  # most of a long run's spans miss a given chunk
            inside = (t >= begin) & (t < end)
            counted[label] = counted[label] | inside
            one.add(t, total, parts, inside)
        for label, budget in self.labels.items():
            budget.add(t, total, parts, counted[label])

    def rows(self) -> dict[str, dict[str, float]]:
        """{label: :meth:`BudgetStats.row`} of each label with samples, with
        :func:`spread_over_spans` where a label has several spans."""
        rows = {}
        for label, budget in self.labels.items():
            tests = [
                one for (name, _, _), one in zip(self.spans, self.each) if name == label and one.n
            ]
            # a span the run is too short for (the creep's steady state on the smoke DAG)
            # has no row
            if budget.n:
                rows[label] = budget.row() | (spread_over_spans(tests) if len(tests) > 1 else {})
        return rows


def spread_over_spans(tests: Sequence[BudgetStats]) -> dict[str, float]:
    """σ over the spans (P1's tests, ddof = 1 as Table 6.1's) of each span's max error, and of the
    signed error at that max and of each source there: the sources' values add up to that signed
    error, so its variance is theirs with their covariances."""
    um = 1e6
    row = {
        "tests": len(tests),
        "total max σ over tests [µm]": float(np.std([s.total_max for s in tests], ddof=1)) * um,
        "σ over tests of the signed error at max [µm]": float(
            np.std([s.total_at_max for s in tests], ddof=1)
        )
        * um,
    }
    return row | {
        f"{source}{AT_MAX_SPREAD}": float(np.std([s.at_max[source] for s in tests], ddof=1)) * um
        for source in tests[0].sources
    }


#: the channels the budget streams, as rule `observe` does, so that the chunks are the same
CHANNELS = ("Ur", "Ir", "I", "x_laser")


def capture_budget(
    path,
    n_periods: int,
    gamma: GammaPolynomial,
    gains: HPOGains,
    omega_c: float | None = None,
    p1_protocol: Mapping | None = None,
    transient_s: float | None = None,
) -> dict[str, dict[str, float]]:
    """:func:`run_budget` of one simulated capture, counted as Table 5.4 counts, from the warm-up on
    (given the creep run's ``transient_s``, in its transient and steady state as its table counts,
    :func:`selfsense.chapters.ch5.creep_phases`); given the loop's ``omega_c``, as Chapter 6 counts
    a closed-loop run: at the loop's rate, from its settling on (Table 6.2), or, given P1's
    protocol, in each segment's steady windows (Table 6.1,
    :func:`selfsense.chapters.ch6.segment_windows`)."""
    windows = segment_windows(p1_protocol, omega_c) if p1_protocol else ()
    with open_capture(path, require=CHANNELS) as cap:
        truth = Truth.from_capture(cap)
        warmup, plan = float(cap.attribute("warmup_s")), plan_from_capture(cap, n_periods)
        if omega_c is None:
            phases = creep_phases(warmup, transient_s) if transient_s is not None else ()
            return run_budget(
                cap.iter_chunks(CHANNELS), plan, gamma, gains, cap.fs, warmup, truth, windows=phases
            )
        return run_budget(
            cap.iter_chunks(CHANNELS),
            plan,
            gamma,
            gains,
            cap.fs,
            settled_after(warmup, omega_c),
            truth,
            loop_rate=plan_from_capture(cap, 1),
            windows=windows,
        )


def budget_table(
    runs: Mapping[str, tuple],
    n_periods: int,
    gamma: GammaPolynomial,
    gains: HPOGains,
) -> pd.DataFrame:
    """Rule error_budget's table: :func:`capture_budget` of each run, one row per run and
    segment, the run named by its capture.

    ``runs``: {capture path: (Table 5.4 frequency [Hz] or None, the loop's ω_C for a Chapter 6
    closed-loop run or None, the protocol of a P1 run or None, the creep run's transient [s] or
    None)}: Table 5.4's runs are counted as that table counts them, Chapter 6's as ε_OCL
    (Tables 6.1, 6.2)."""
    return pd.DataFrame(
        [
            {"run": Path(c).stem, "segment": s or None, "frequency [Hz]": f} | row
            for c, (f, w, p1, transient) in runs.items()
            for s, row in capture_budget(c, n_periods, gamma, gains, w, p1, transient).items()
        ]
    ).astype({"frequency [Hz]": float})


#: the sources of the charge–position error (Fig 5.2), in the order they telescope
CHARGE_SOURCES = ("current path", "q–x map", "laser")


def charge_position_budget(
    series: Mapping[str, np.ndarray], truth: Truth, fs: float, block_len: int
) -> dict[str, float]:
    """Fig 5.2's charge–position error, x_I − x_laser with x_I = q/a0
    (:func:`selfsense.chapters.ch5.charge_sensing`: the integrated current with q0 + I_0·t fitted
    out, the laser from its start), split at the truth's charge q and position x over the same
    windows of ``block_len`` samples, x taken from its first window as the laser is:

        q_c/a0 − x_laser = (q_c − q − c)/a0 + ((q + c)/a0 − x) + (x − x_laser)
                           current path       q–x map             laser

    with c the mean of q_c − q (the fit's charge offset, so that the current path has zero mean).
    The current path holds the probe's resolution and offset as far as the fit leaves them, and
    the integrated ripple current; the q–x map the q–x hysteresis and a0's error. Returns
    :meth:`BudgetStats.row` over the whole record, "total max error [µm]" being the table's."""
    x_laser, q_c, fit = offset_compensated_charge(series)
    last = np.rint(series["time"] * fs + (block_len - 1) / 2).astype(np.int64)
    true = truth.means(last, block_len)
    q, x = true["q"] + float(np.mean(q_c - true["q"])), true["x"] - true["x"][0]
    a0 = fit.a1
    parts = {"current path": (q_c - q) / a0, "q–x map": q / a0 - x, "laser": x - x_laser}
    stats = BudgetStats(CHARGE_SOURCES)
    stats.add(series["time"], q_c / a0 - x_laser, parts, np.ones(len(last), dtype=bool))
    return stats.row()


def capture_charge_budget(series, capture, n_periods: int) -> dict[str, float]:
    """:func:`charge_position_budget` of one Chapter 5 sine: its ripple series (rule
    ``extract_ripple``, windows of ``n_periods`` folded periods) and the simulated capture it came
    from."""
    with open_capture(capture) as cap:
        truth = Truth.from_capture(cap, names=("x", "q"))
        fs, block_len = cap.fs, plan_from_capture(cap, n_periods).block_len
    return charge_position_budget(read_series(series), truth, fs, block_len)
