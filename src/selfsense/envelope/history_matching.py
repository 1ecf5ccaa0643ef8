"""History matching: the implausibility of the twin's unknowns given what the thesis measured,
the region it does not rule out, and the waves' designs that refocus the runs there.

For a target i asserting z_i (a printed value, or a bound: an interval [z_lo, z_hi], one edge
infinite) and a point x of the unknowns, the implausibility is (Craig et al. 1997; Vernon,
Goldstein & Bower 2010, Eq. 3; Andrianakis et al. 2015, Eq. 4 for a stochastic simulator)

    I_i(x) = d_i(x) / √(Var_em,i(x) + Var_ens,i + Var_obs,i + Var_md,i),
    d_i(x) = max(0, z_lo,i − E[f_i(x)], E[f_i(x)] − z_hi,i)        (= |z_i − E[f_i(x)]| for a value)

with E[f_i(x)] and Var_em,i(x) the emulator's, Var_ens,i the ensemble's (the seed's noise, from
replicates), Var_obs,i and Var_md,i the declared observation and discrepancy variances, all on
the target's transformed scale. A point is ruled out where the largest I_i exceeds the cutoff
(3), or the second largest once there are enough targets (:func:`cut_rank`): the region not
ruled out yet (NROY). Wave 1 is a maximin Latin hypercube over the prior (the unit cube of the
unknowns' prior quantiles, where every declared distribution is uniform); later waves a maximin
subset of the prior candidates inside NROY, on the common targets only, so that no judged row
steers where the simulator runs. Replicates at a few points measure Var_ens.

Arrays in, arrays out: points are rows of the unit cube, targets are columns. :func:`run_waves`
drives a simulator given as a function (an analytic one in the tests; the twin's runs are jobs of
the workflow, which call the same steps).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from scipy.spatial.distance import pdist
from scipy.stats import qmc

from selfsense.envelope.emulator import Emulator, LeaveOneOut, Settings, fit, leave_one_out


def implausibility(
    z_low: np.ndarray,
    z_high: np.ndarray,
    mean: np.ndarray,
    var_em: np.ndarray,
    var_other: np.ndarray,
) -> np.ndarray:
    """I (points × targets): the distance of E[f(x)] from what each target asserts over the sd
    of everything that separates them (module docstring; Vernon et al. 2010, Eq. 3).

    ``z_low``/``z_high`` (targets) equal for a value, one infinite for a bound; ``mean`` and
    ``var_em`` (points × targets) the emulators'; ``var_other`` (targets) the sum
    Var_ens + Var_obs + Var_md."""
    mean = np.atleast_2d(mean)
    distance = np.maximum(0.0, np.maximum(z_low - mean, mean - z_high))
    return distance / np.sqrt(np.atleast_2d(var_em) + var_other)


def cut_rank(targets: int, second_maximum_from: int) -> int:
    """Which largest implausibility is cut on: the largest, or the second largest once there are
    ``second_maximum_from`` targets or more (Vernon et al. 2010, Section 3.2; hmer's
    nth_implausible)."""
    return 2 if targets >= second_maximum_from else 1


def nth_largest(values: np.ndarray, n: int) -> np.ndarray:
    """The n-th largest of each row (NaN, a target not emulable here, counts as absent)."""
    values = np.where(np.isnan(values), -np.inf, np.atleast_2d(values))
    if values.shape[1] < n:
        return np.full(values.shape[0], -np.inf)
    return -np.partition(-values, n - 1, axis=1)[:, n - 1]


def not_ruled_out(I: np.ndarray, cutoff: float, second_maximum_from: int) -> np.ndarray:
    """The points (rows of I) whose largest, or second largest, implausibility is within the
    cutoff: the region not ruled out yet (NROY). With no target nothing is ruled out."""
    present = int(np.sum(np.any(~np.isnan(np.atleast_2d(I)), axis=0)))
    if present == 0:
        return np.ones(np.atleast_2d(I).shape[0], dtype=bool)
    return nth_largest(I, cut_rank(present, second_maximum_from)) <= cutoff


def maximin_latin_hypercube(n: int, d: int, seed: int, candidates: int) -> np.ndarray:
    """The Latin hypercube (n × d, unit cube) whose smallest distance between two points is the
    largest among ``candidates`` drawn from ``seed`` (Morris & Mitchell 1995's maximin)."""
    rng = np.random.default_rng(seed)
    best, best_distance = None, -1.0
    for _ in range(max(candidates, 1)):
        design = qmc.LatinHypercube(d=d, seed=rng).random(n)
        distance = pdist(design).min() if n > 1 else 0.0
        if distance > best_distance:
            best, best_distance = design, distance
    return best


def maximin_subset(points: np.ndarray, n: int, seed: int, candidates: int) -> np.ndarray:
    """``n`` of ``points`` (all of them if fewer) spread as far apart as ``candidates`` random
    subsets allow: the space-filling design of a later wave inside NROY."""
    points = np.asarray(points, dtype=float)
    if len(points) <= n:
        return points.copy()
    rng = np.random.default_rng(seed)
    best, best_distance = None, -1.0
    for _ in range(max(candidates, 1)):
        pick = rng.choice(len(points), size=n, replace=False)
        distance = pdist(points[pick]).min() if n > 1 else 0.0
        if distance > best_distance:
            best, best_distance = pick, distance
    return points[np.sort(best)]


def prior_candidates(n: int, d: int, seed: int) -> np.ndarray:
    """``n`` points drawn from the prior (uniform on the cube of prior quantiles), scrambled
    Sobol' so that the screen's fraction of NROY converges faster than at random."""
    m = int(np.ceil(np.log2(max(n, 2))))
    return qmc.Sobol(d=d, scramble=True, seed=seed).random_base2(m)[:n]


def ensemble_variance(replicates: np.ndarray) -> np.ndarray:
    """Var_ens per output from replicates (points × seeds × outputs, on the outputs' scales): the
    pooled within-point sample variance, the seed's noise where the physics is held (Andrianakis
    et al. 2015, Section 2.3). NaN outputs (a run that failed) are left out of their point."""
    replicates = np.asarray(replicates, dtype=float)
    within = np.nanvar(replicates, axis=1, ddof=1)
    return np.nanmean(within, axis=0)


@dataclass(frozen=True)
class Wave:
    """One wave: its runs (unit cube), the outputs there (runs × targets), the emulators fitted
    on all runs so far with their leave-one-out diagnostics, and the fraction of the prior
    candidates it leaves not ruled out."""

    design: np.ndarray
    outputs: np.ndarray
    emulators: tuple[Emulator | None, ...]
    diagnostics: tuple[LeaveOneOut | None, ...]
    nroy_fraction: float


@dataclass(frozen=True)
class Matching:
    """History matching's result: the waves, Var_ens per target as the replicates measured it,
    what the targets assert and their declared Var_obs + Var_md, and the prior candidates with
    the mask of those not ruled out."""

    waves: tuple[Wave, ...]
    replicate_var: np.ndarray
    z_low: np.ndarray
    z_high: np.ndarray
    var_obs_md: np.ndarray
    cutoff: float
    second_maximum_from: int
    candidates: np.ndarray
    nroy: np.ndarray

    @property
    def emulators(self) -> tuple[Emulator | None, ...]:
        return self.waves[-1].emulators

    @property
    def var_ens(self) -> np.ndarray:
        """Var_ens per target: the last wave's nuggets."""
        return nuggets(self.emulators)

    def not_ruled_out(self, X: np.ndarray) -> np.ndarray:
        """The mask of the points of ``X`` no wave rules out (each wave's emulators cut where
        they were trained, so a point must pass all of them)."""
        mask = np.ones(len(X), dtype=bool)
        for wave in self.waves:
            mask &= screen(
                wave.emulators,
                X,
                self.z_low,
                self.z_high,
                self.var_obs_md,
                self.cutoff,
                self.second_maximum_from,
            )
        return mask


def emulate(
    X: np.ndarray,
    Y: np.ndarray,
    settings: Settings,
    var_ens: np.ndarray,
    var_ens_df: int | None = None,
) -> tuple[tuple[Emulator | None, ...], tuple[LeaveOneOut | None, ...]]:
    """One emulator per output column of ``Y`` (runs with a NaN output left out of it), its nugget
    at the measured Var_ens (within its estimate's interval, given its degrees of freedom); None
    where the diagnostics say not emulable."""
    emulators, diagnostics = [], []
    for k in range(Y.shape[1]):
        ok = np.isfinite(Y[:, k])
        emulator = fit(X[ok], Y[ok, k], settings, noise_var=float(var_ens[k]), noise_df=var_ens_df)
        loo = leave_one_out(emulator, settings)
        emulators.append(emulator if loo.emulable else None)
        diagnostics.append(loo)
    return tuple(emulators), tuple(diagnostics)


def predict_all(
    emulators: Sequence[Emulator | None], X: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """E[f(x)] and Var_em(x) (points × outputs); NaN for an output not emulable."""
    mean = np.full((len(X), len(emulators)), np.nan)
    var = np.full_like(mean, np.nan)
    for k, emulator in enumerate(emulators):
        if emulator is not None:
            mean[:, k], var[:, k] = emulator.predict(X)
    return mean, var


def nuggets(emulators: Sequence[Emulator | None]) -> np.ndarray:
    """Var_ens per output: each emulator's nugget (NaN where not emulable)."""
    return np.array([np.nan if e is None else e.nugget for e in emulators])


def screen(
    emulators: Sequence[Emulator | None],
    X: np.ndarray,
    z_low: np.ndarray,
    z_high: np.ndarray,
    var_obs_md: np.ndarray,
    cutoff: float,
    second_maximum_from: int,
) -> np.ndarray:
    """The mask of the points of ``X`` the emulated targets do not rule out, Var_ens being each
    emulator's nugget (the seed's noise, fitted on every run within the replicates' interval)
    and ``var_obs_md`` the declared Var_obs + Var_md."""
    mean, var = predict_all(emulators, X)
    other = nuggets(emulators) + var_obs_md
    return not_ruled_out(
        implausibility(z_low, z_high, mean, var, other), cutoff, second_maximum_from
    )


@dataclass(frozen=True)
class Streams:
    """Every random number the waves use, drawn in one order from the declared seed: each run's
    noise seed (in run order over all waves), wave 1's maximin design, the prior candidates the
    waves screen, and each later wave's maximin subset. :func:`run_waves` and the workflow's
    waves (:mod:`selfsense.envelope.campaign`) take them from here, so that the same declaration
    gives the same runs whichever drives them."""

    runs: np.ndarray  # uint64 noise seeds, in run order
    design: int
    candidates: int
    later: tuple[int, ...]


#: how many noise seeds a declaration's waves may draw, and how many later waves
SEEDS, LATER_WAVES = 10**6, 64


def streams(seed: int) -> Streams:
    """The waves' random numbers from ``seed`` (see :class:`Streams`)."""
    rng = np.random.default_rng(seed)
    runs = rng.integers(0, 2**32 - 1, size=SEEDS, dtype=np.uint64)
    design, candidates = int(rng.integers(2**31)), int(rng.integers(2**31))
    return Streams(
        runs,
        design,
        candidates,
        tuple(int(rng.integers(2**31)) for _ in range(LATER_WAVES)),
    )


def run_waves(
    simulate: Callable[[np.ndarray, np.ndarray], np.ndarray],
    d: int,
    z_low: np.ndarray,
    z_high: np.ndarray,
    var_obs_md: np.ndarray,
    *,
    cutoff: float,
    second_maximum_from: int,
    first_runs: int,
    later_runs: int,
    replicate_points: int,
    replicate_seeds: int,
    candidates: int,
    max_waves: int,
    shrink_below: float,
    seed: int,
    settings: Settings,
    maximin_candidates: int = 20,
) -> Matching:
    """History matching in waves on the targets (columns) of ``simulate(X, seeds)`` → outputs
    (runs × targets, transformed), each run with its own seed (the seed is noise, not a factor).

    Wave 1: a maximin Latin hypercube of ``first_runs``, and ``replicate_points`` of its points
    run ``replicate_seeds`` times in all for Var_ens (the nugget is fitted within that
    estimate's interval, on every run). Each wave refits the emulators on every run so far
    and screens the prior ``candidates``; the next wave is a maximin subset of the survivors.
    Stops after ``max_waves``, or when a wave rules out less than ``shrink_below`` of what the
    last left (the declaration's stopping rule), or when nothing is left."""
    drawn = streams(seed)
    seeds, later = iter(drawn.runs), iter(drawn.later)

    def run(X: np.ndarray) -> np.ndarray:
        return simulate(X, np.array([next(seeds) for _ in range(len(X))]))

    design = maximin_latin_hypercube(first_runs, d, drawn.design, maximin_candidates)
    outputs = run(design)
    # replicates: the first points run again with fresh seeds; they measure Var_ens, and every
    # run, replicate or not, trains the emulators (the nugget is fitted on all of them)
    points = design[: max(replicate_points, 0)]
    repeats = [run(points) for _ in range(replicate_seeds - 1)]
    reps = np.stack([outputs[: len(points)], *repeats], axis=1)
    replicate_var = ensemble_variance(reps)
    df = len(points) * (replicate_seeds - 1)
    cands = prior_candidates(candidates, d, drawn.candidates)
    X_all = np.vstack([design, *[points] * len(repeats)])
    Y_all = np.vstack([outputs, *repeats])
    waves: list[Wave] = []
    last = 1.0
    mask = np.ones(len(cands), dtype=bool)
    for w in range(max_waves):
        emulators, diagnostics = emulate(X_all, Y_all, settings, replicate_var, df)
        # a later wave's emulators cut within the earlier waves' NROY: the points outside it
        # were ruled out by emulators trained where they are, and the new ones never saw them
        mask = mask & screen(
            emulators, cands, z_low, z_high, var_obs_md, cutoff, second_maximum_from
        )
        fraction = float(mask.mean())
        waves.append(Wave(design, outputs, emulators, diagnostics, fraction))
        shrink = 1.0 - fraction / last if last > 0 else 0.0
        if w + 1 == max_waves or fraction == 0.0 or (w > 0 and shrink < shrink_below):
            break
        last = fraction
        design = maximin_subset(cands[mask], later_runs, next(later), maximin_candidates)
        outputs = run(design)
        X_all, Y_all = np.vstack([X_all, design]), np.vstack([Y_all, outputs])
    return Matching(
        tuple(waves),
        replicate_var,
        np.asarray(z_low, dtype=float),
        np.asarray(z_high, dtype=float),
        np.asarray(var_obs_md, dtype=float),
        cutoff,
        second_maximum_from,
        cands,
        mask,
    )
