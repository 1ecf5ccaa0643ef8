"""The validation's verdicts from the ensemble's tables alone: emulators, waves, every fold
predicted from the others, the fold-compatibility map and the pseudo-theses' coverage.

The tables (:mod:`selfsense.envelope.campaign`: members × inputs, members × rows, members ×
targets) and the declaration (:func:`selfsense.envelope.validation.load_validation`) are all it
reads: changing a table re-judges without a run. In order:

1. every column (a common target or an emergent row) on its declared scale, with the noise
   variance its replicates measure (runs of one design point, pooled) and one Gaussian-process
   emulator fitted on every run, its leave-one-out diagnostics printed; a column with too few
   values, the same value everywhere or failed diagnostics is "not emulable" and neither rules
   out nor conditions (:mod:`selfsense.envelope.emulator`);
2. the waves: per wave, the share of the prior candidates the common targets' emulators fitted
   on the runs so far leave (each wave cuts within the last), and the next wave's design, a
   maximin subset of what is left (:func:`next_wave`: on the common targets only, so that no
   judged row steers where the simulator runs);
3. every fold predicted from the others at the declared number of prior points
   (:func:`selfsense.envelope.fold_prediction.predict_folds`) and the compatibility map;
4. the pseudo-theses: the declared number of runs, each the only run at its point, held out of a
   second set of emulators fitted on the others, their numbers printed as the thesis prints, each
   taken as the published values through the same leave-one-fold-out
   (:func:`selfsense.envelope.coverage.pseudo_theses`);
5. what drives each column: every unknown's first-order Sobol' index on the column's emulator as
   a share of its variance, and the noise's share (:func:`drivers`).

Frames and text out; nothing is read or written.
"""

from __future__ import annotations

import functools
import math
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import pandas as pd
from threadpoolctl import threadpool_limits

from selfsense.envelope.campaign import FAILED_COLUMN, MEMBER, Runs, runs_of_later_wave
from selfsense.envelope.coverage import Coverage, benches, binomial_band, printed, pseudo_theses
from selfsense.envelope.design import MEMBER_MARK
from selfsense.envelope.emulator import (
    Emulator,
    LeaveOneOut,
    Settings,
    active_inputs,
    fit,
    leave_one_out,
    sobol_shares,
)
from selfsense.envelope.fold_prediction import (
    INCOMPATIBLE,
    INCONSISTENT,
    NOT_EMULABLE,
    VERDICTS,
    RowPrediction,
    compatibility,
    conditioning,
    declared_columns,
    predict_folds,
)
from selfsense.envelope.history_matching import (
    maximin_subset,
    nuggets,
    predict_all,
    prior_candidates,
    screen,
    streams,
)
from selfsense.envelope.validation import inverse, transform
from selfsense.envelope.verdicts import row_key
from selfsense.scorecard.registry import Entry, last_digit

#: an emulator needs at least this many runs that gave its column a value
MIN_RUNS = 5


@dataclass(frozen=True)
class Ensemble:
    """The tables as arrays: members, runs × unknowns (unit cube), runs × columns (the
    declaration's targets then rows, on their declared scales; NaN where a run gave none, and
    for a row the registry gives no verdict), each run's wave and design point."""

    members: list[str]
    X: np.ndarray
    Y: np.ndarray
    wave: np.ndarray
    point: np.ndarray
    names: list[str]


def column_names(declaration) -> list[str]:
    """The columns' names: the targets' ids, then the rows as the tables name them."""
    return [t.id for t in declaration.targets] + [
        row_key(r.source, r.quantity) for r in declaration.rows
    ]


def ensemble(
    declaration, ids: Sequence[str], inputs: pd.DataFrame, rows: pd.DataFrame, targets: pd.DataFrame
) -> Ensemble:
    """The ensemble of the batches' tables (concatenated), the unknowns ``ids`` in order."""
    members = list(inputs[MEMBER])
    rows = rows.set_index(MEMBER).reindex(members)
    targets = targets.set_index(MEMBER).reindex(members)
    columns = []
    for t in declaration.targets:
        raw = targets[t.id] if t.id in targets else pd.Series(np.nan, index=members)
        columns.append(_scaled(t.transform, raw))
    for r in declaration.rows:
        key = row_key(r.source, r.quantity)
        raw = rows[key] if key in rows and r.judged else pd.Series(np.nan, index=members)
        columns.append(_scaled(r.transform, raw))
    Y = np.column_stack(columns) if columns else np.zeros((len(members), 0))
    # a design point is one of its own validation's: runs of joined validations never replicate
    own = [str(m).split(MEMBER_MARK, 1)[0] for m in members]
    keys = list(zip(own, inputs["wave"].astype(int), inputs["point"].astype(int)))
    return Ensemble(
        members,
        inputs[list(ids)].to_numpy(dtype=float),
        Y,
        inputs["wave"].to_numpy(dtype=int),
        pd.factorize(pd.Series(keys, dtype=object))[0].astype(int),
        column_names(declaration),
    )


def _scaled(kind: str, values: pd.Series) -> np.ndarray:
    with np.errstate(divide="ignore", invalid="ignore"):
        out = transform(kind, pd.to_numeric(values, errors="coerce").to_numpy(dtype=float))
    return np.where(np.isfinite(out), out, np.nan)


def replicate_variance(Y: np.ndarray, wave: np.ndarray, point: np.ndarray):
    """(Var_ens, degrees of freedom) per column: the pooled within-point variance of the runs of
    one design point (Andrianakis et al. 2015), NaN with 0 degrees of freedom where no point has
    two runs with a value."""
    keys = wave * 10**6 + point
    ss, df = np.zeros(Y.shape[1]), np.zeros(Y.shape[1], dtype=int)
    for key in np.unique(keys):
        group = Y[keys == key]
        if len(group) < 2:
            continue
        n = np.sum(np.isfinite(group), axis=0)
        with np.errstate(invalid="ignore"), warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # a column no run of it gave
            dev = np.nansum((group - np.nanmean(group, axis=0)) ** 2, axis=0)
        ss += np.where(n >= 2, dev, 0.0)
        df += np.maximum(n - 1, 0)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(df > 0, ss / np.maximum(df, 1), np.nan), df


@dataclass(frozen=True)
class Fitted:
    """One column's emulator (None: not emulable), its diagnostics and why it failed."""

    emulator: Emulator | None
    runs: int
    loo: LeaveOneOut | None
    reason: str


def emulate(
    X: np.ndarray,
    Y: np.ndarray,
    settings: Settings,
    var: np.ndarray,
    df: np.ndarray,
    judged: np.ndarray,
) -> list[Fitted]:
    """Every judged column's emulator on the runs that gave it a value, its nugget within the
    replicates' interval where they measured it (else fitted within the declared bounds)."""
    out = []
    for k in range(Y.shape[1]):
        ok = np.isfinite(Y[:, k])
        n = int(ok.sum())
        if not judged[k]:
            out.append(Fitted(None, n, None, "no verdict in the registry"))
            continue
        if n < MIN_RUNS:
            out.append(Fitted(None, n, None, f"{n} runs gave a value (at least {MIN_RUNS})"))
            continue
        if np.ptp(Y[ok, k]) == 0.0:
            out.append(Fitted(None, n, None, "the same value in every run"))
            continue
        noise = float(var[k]) if np.isfinite(var[k]) and var[k] > 0 else None
        # at most the declared number of active inputs, and no more than the runs can fit a
        # linear mean to with residuals left for the process (three runs an input)
        most = max(1, min(settings.max_active, (n - 2) // 3))
        active = active_inputs(X[ok], Y[ok, k], most, settings.min_index)
        try:
            emulator = fit(X[ok], Y[ok, k], settings, noise, active, int(df[k]) if noise else None)
            loo = leave_one_out(emulator, settings)
        except (np.linalg.LinAlgError, ValueError) as err:
            out.append(Fitted(None, n, None, f"the fit failed ({err})"))
            continue
        out.append(Fitted(emulator if loo.emulable else None, n, loo, loo.reason))
    return out


def emulators_of(fitted: Sequence[Fitted]) -> list[Emulator | None]:
    return [f.emulator for f in fitted]


#: the share of a column's variance the nugget holds, named as a driver beside the unknowns
NOISE = "noise"


def drivers(
    fitted: Sequence[Fitted], d: int, base: int, seed: int
) -> tuple[np.ndarray, np.ndarray]:
    """(columns × d shares, columns noise share): each emulable column's Sobol' shares of its
    variance over the prior (:func:`selfsense.envelope.emulator.sobol_shares`), NaN for a column
    that is not emulable."""
    shares = np.full((len(fitted), d), np.nan)
    noise = np.full(len(fitted), np.nan)
    for k, f in enumerate(fitted):
        if f.emulator is not None:
            shares[k], noise[k] = sobol_shares(f.emulator, d, base, seed)
    return shares, noise


def driver_text(shares: np.ndarray, noise: float, ids: Sequence[str], top: int) -> str:
    """The ``top`` largest shares of one column, largest first, and the noise's: "a 41 %, b 12 %;
    noise 30 %" (empty for a column that is not emulable)."""
    if not np.isfinite(noise):
        return ""
    order = [i for i in np.argsort(shares)[::-1][:top] if shares[i] >= 0.005]
    named = ", ".join(f"{ids[i]} {100 * shares[i]:.0f} %" for i in order)
    return f"{named}; {NOISE} {100 * noise:.0f} %" if named else f"{NOISE} {100 * noise:.0f} %"


def sobol_table(names: Sequence[str], ids: Sequence[str], shares, noise) -> pd.DataFrame:
    """Long format: per emulable column, every unknown's share and the noise's."""
    out = []
    for k, name in enumerate(names):
        if not np.isfinite(noise[k]):
            continue
        out += [{"column": name, "unknown": u, "share": shares[k, i]} for i, u in enumerate(ids)]
        out.append({"column": name, "unknown": NOISE, "share": noise[k]})
    return pd.DataFrame(out, columns=["column", "unknown", "share"])


@dataclass(frozen=True)
class WaveCut:
    """The common targets' cut after each wave: runs so far, the share of the prior candidates
    left, and the mask of the candidates left after the last."""

    runs: list[int]
    fractions: list[float]
    mask: np.ndarray
    emulator_share: float  # the largest over targets of mean Var_em / (Var_ens + obs + md) left


def wave_cuts(
    ens: Ensemble, declaration, settings: Settings, candidates: np.ndarray, judged: np.ndarray
) -> WaveCut:
    """Per wave, the common targets' emulators fitted on the runs of that wave and the earlier
    ones, each cutting the prior ``candidates`` within what the earlier waves left."""
    targets = declaration.targets
    k = len(targets)
    columns = declared_columns(declaration)
    mask = np.ones(len(candidates), dtype=bool)
    runs, fractions, share = [], [], math.nan
    for w in sorted(set(ens.wave)):
        seen = ens.wave <= w
        Y = ens.Y[seen, :k]
        var, df = replicate_variance(Y, ens.wave[seen], ens.point[seen])
        fitted = emulate(ens.X[seen], Y, settings, var, df, judged[:k])
        emulators = emulators_of(fitted)
        mask = mask & screen(
            emulators,
            candidates,
            columns.z_low[:k],
            columns.z_high[:k],
            columns.var_obs_md[:k],
            declaration.cutoff,
            declaration.second_maximum_from,
        )
        runs.append(int(seen.sum()))
        fractions.append(float(mask.mean()))
        if mask.any():
            _, var_em = predict_all(emulators, candidates[mask])
            other = nuggets(emulators) + columns.var_obs_md[:k]
            with np.errstate(invalid="ignore"), warnings.catch_warnings():
                warnings.simplefilter("ignore", RuntimeWarning)  # a target not emulable: all NaN
                ratio = np.nanmean(var_em, axis=0) / other
            share = float(np.nanmax(ratio)) if np.isfinite(ratio).any() else math.nan
    return WaveCut(runs, fractions, mask, share)


def next_wave(
    ens: Ensemble, declaration, d: int, first: int
) -> tuple[Runs | None, list[float], str]:
    """The next wave's runs from the waves so far (common targets only), or None with the
    reason the waves stop (the declaration's stopping rule); the cut's fractions per wave."""
    waves = declaration.settings["waves"]
    later, stop = waves["later"], waves["stop"]
    drawn = streams(int(waves["seed"]))
    settings = Settings.from_declaration(declaration.settings["emulator"], int(waves["seed"]))
    candidates = prior_candidates(int(later["candidates"]), d, drawn.candidates)
    judged = np.ones(len(declaration.targets), dtype=bool)
    cut = wave_cuts(ens, declaration, settings, candidates, judged)
    done, fractions = len(cut.fractions), cut.fractions
    shrink = 1.0 - fractions[-1] / fractions[-2] if done > 1 and fractions[-2] > 0 else 1.0
    if done >= int(stop["max_waves"]):
        return None, fractions, f"the declared {stop['max_waves']} waves are done"
    if fractions[-1] == 0.0:
        return None, fractions, "the common targets leave no candidate"
    if shrink < float(stop["nroy_shrink_below"]):
        return None, fractions, f"wave {done} ruled out {shrink:.0%} of what the last left"
    if cut.emulator_share < float(stop["emulator_to_other_variance_below"]):
        return None, fractions, "the emulators' variance is below the declared share"
    design = maximin_subset(
        candidates[cut.mask],
        int(later["runs"]),
        drawn.later[done - 1],
        int(later["maximin_candidates"]),
    )
    runs = runs_of_later_wave(design, later["replicates"], drawn.runs, done + 1, first)
    return runs, fractions, ""


@dataclass(frozen=True)
class Judgement:
    """What rule `validation_verdicts` writes: the verdicts (one row per emergent row), the
    emulators' diagnostics, the waves' cut, the compatibility map, the pseudo-theses' coverage
    (one row per pseudo-thesis, one per held-out row's PIT), the Sobol' shares (long), the PIT
    histogram and the summary."""

    verdicts: pd.DataFrame
    emulators: pd.DataFrame
    waves: pd.DataFrame
    compatibility: pd.DataFrame
    coverage: pd.DataFrame
    pit: pd.DataFrame
    sobol: pd.DataFrame
    histogram: np.ndarray
    summary: str

    @property
    def headline_pit(self) -> pd.DataFrame:
        """The PIT rows of the declaration's latest test (the one its histogram draws)."""
        return headline(self.pit)


def headline(pit: pd.DataFrame) -> pd.DataFrame:
    """A PIT table's rows of its last test (all of a table made before tests were named)."""
    if "test" not in pit or not len(pit):
        return pit
    return pit[pit["test"] == pit["test"].iloc[-1]]


def pseudo_benches(
    ens: Ensemble, count: int, seed: int, fixed: Mapping[int, float] | None = None
) -> np.ndarray:
    """The runs taken as pseudo-theses: ``count`` (at most a quarter of them) of the runs that
    are the only run at their design point, chosen with ``seed`` (their points' noise is not in
    any other run the emulators train on), and benches of the model judged: at every input of
    ``fixed`` ({column: unit value}) its value."""
    keys = ens.wave * 10**6 + ens.point
    model = np.ones(len(keys), dtype=bool)
    for j, value in (fixed or {}).items():
        model &= np.isclose(ens.X[:, j], value, rtol=0.0, atol=1e-9)
    alone = np.flatnonzero(np.array([np.sum(keys == k) == 1 for k in keys]) & model)
    n = min(count, len(alone) // 4)
    if n <= 0:
        return np.zeros(0, dtype=int)
    return np.sort(np.random.default_rng(seed).choice(alone, size=n, replace=False))


def digits(declaration, entries: Sequence[Entry]) -> np.ndarray:
    """Each column's last printed digit: a row's as the registry prints it, a target's of its
    declared value (a signature's band centre)."""
    by_key = {(e.source, e.quantity): e for e in entries}
    out = []
    for t in declaration.targets:
        edge = t.low if np.isfinite(t.low) else t.high
        value = float(inverse(t.transform, np.array(edge)))
        out.append(last_digit(_text(value)))
    for r in declaration.rows:
        e = by_key.get((r.source, r.quantity))
        out.append(last_digit(e.printed if e is not None and e.printed else _text(r.published)))
    return np.array(out, dtype=float)


def _text(value: float) -> str:
    text = f"{value:.6g}"
    return text if "e" not in text else repr(float(text))


def held_points(points: np.ndarray, ids: Sequence[str], fixed: Mapping[str, float]) -> np.ndarray:
    """The candidates with every input of ``fixed`` at its unit value."""
    out = np.array(points, dtype=float, copy=True)
    for name, value in fixed.items():
        out[:, list(ids).index(name)] = value
    return out


def one_blas_thread(fn):
    """``fn`` with one BLAS thread: the emulators' matrices are a few hundred runs wide, where a
    second thread costs more than it gives, and a job beside another on two cores (the member
    jobs' case) makes two threads fight for one core (docs/performance.md)."""

    @functools.wraps(fn)
    def run(*args, **kwargs):
        with threadpool_limits(limits=1):
            return fn(*args, **kwargs)

    return run


@one_blas_thread
def judge(
    declaration,
    entries: Sequence[Entry],
    ids: Sequence[str],
    inputs: pd.DataFrame,
    rows: pd.DataFrame,
    targets: pd.DataFrame,
    sobol_base: int = 1024,
    top: int = 3,
    fixed: Mapping[str, float] | None = None,
) -> Judgement:
    """The verdicts of the ensemble's tables under the declaration (module docstring); each
    row's drivers its ``top`` largest Sobol' shares on ``sobol_base`` · (k + 2) emulator
    points. ``fixed`` ({unknown: unit value}) holds inputs of the model judged where the prior
    candidates and the pseudo-theses put them (a variant validation's held unknowns). With one BLAS
    thread (:func:`one_blas_thread`)."""
    s = declaration.settings
    seed = int(s["waves"]["seed"])
    settings = Settings.from_declaration(s["emulator"], seed)
    ens = ensemble(declaration, ids, inputs, rows, targets)
    columns = declared_columns(declaration)
    d = len(ids)
    fixed = dict(fixed or {})
    points = prior_candidates(int(s["prediction"]["samples"]), d, streams(seed).candidates)
    points = held_points(points, ids, fixed)
    var, df = replicate_variance(ens.Y, ens.wave, ens.point)
    fitted = emulate(ens.X, ens.Y, settings, var, df, columns.judged)
    cut = wave_cuts(ens, declaration, settings, points, columns.judged)
    mean, var_em = predict_all(emulators_of(fitted), points)
    var_ens = nuggets(emulators_of(fitted))
    kw = {"cutoff": declaration.cutoff, "second_maximum_from": declaration.second_maximum_from}
    preds = predict_folds(
        columns, mean, var_em, var_ens, quantiles=s["prediction"]["quantiles"], **kw
    )
    folds, table = compatibility(columns, mean, var_em, var_ens, **kw)
    # the pseudo-theses: held out of a second set of emulators, judged by it
    pt = s["pseudo_theses"]
    at = {list(ids).index(k): v for k, v in fixed.items()}
    chosen = pseudo_benches(ens, int(pt["count"]), int(pt["seed"]), at)
    if len(chosen):
        keep = np.setdiff1d(np.arange(len(ens.members)), chosen)
        var2, df2 = replicate_variance(ens.Y[keep], ens.wave[keep], ens.point[keep])
        fitted2 = emulate(ens.X[keep], ens.Y[keep], settings, var2, df2, columns.judged)
    else:  # no run to hold out: nothing is judged, no second set is fitted
        fitted2 = [Fitted(None, 0, None, "") for _ in fitted]
    mean2, var_em2 = predict_all(emulators_of(fitted2), points)
    transforms = [t.transform for t in declaration.targets] + [
        r.transform for r in declaration.rows
    ]
    md_sd = [t.md_sd for t in declaration.targets] + [r.md_sd for r in declaration.rows]
    last = digits(declaration, entries)
    covs = {
        test: pseudo_theses(
            columns,
            mean2,
            var_em2,
            nuggets(emulators_of(fitted2)),
            printed(values, transforms, last),
            **kw,
        )
        for test, values in benches(ens.Y[chosen], md_sd, pt.get("discrepancy")).items()
    }
    cov = list(covs.values())[-1]  # the declaration's latest test: the headline
    shares, noise = drivers(fitted, d, sobol_base, seed)
    texts = [driver_text(shares[k], noise[k], ids, top) for k in range(len(fitted))]
    verdicts = verdict_table(declaration, entries, columns, preds, fitted, emulable_of(mean), texts)
    return Judgement(
        verdicts=verdicts,
        emulators=emulator_table(ens, fitted, ids, var, df),
        waves=pd.DataFrame(
            {"wave": sorted(set(ens.wave)), "runs": cut.runs, "NROY fraction": cut.fractions}
        ),
        compatibility=pd.DataFrame(
            table, index=pd.Index(folds, name="fold"), columns=folds
        ).reset_index(),
        coverage=pd.concat([coverage_table(ens, chosen, c, k) for k, c in covs.items()]),
        pit=pd.concat([pit_table(ens, chosen, c, k) for k, c in covs.items()]),
        sobol=sobol_table(ens.names, ids, shares, noise),
        histogram=cov.histogram,
        summary=summary(
            declaration, ens, verdicts, fitted, cut, folds, table, covs, df, failures(rows)
        ),
    )


def emulable_of(mean: np.ndarray) -> np.ndarray:
    return ~np.any(np.isnan(np.atleast_2d(mean)), axis=0)


def verdict_table(
    declaration,
    entries: Sequence[Entry],
    columns,
    preds: Sequence[RowPrediction],
    fitted: Sequence[Fitted],
    emulable: np.ndarray,
    texts: Sequence[str],
) -> pd.DataFrame:
    """One row per emergent row: the fold, the folds it is conditioned on, the share of the
    points its region keeps, the posterior predictive's quantiles in the row's unit, the
    published value's least implausibility and PIT, the verdict, what drives it (``texts``, per
    column), and the row's emulator's leave-one-out diagnostics (why it is not emulable)."""
    by_key = {(e.source, e.quantity): e for e in entries}
    k = len(declaration.targets)
    fold_rows = {}
    for f in columns.folds:
        mask = conditioning(columns, f, emulable)
        named = sorted({str(columns.fold[c]) for c in np.flatnonzero(mask) if c >= k})
        fold_rows[f] = (", ".join(named), int(mask[:k].sum()))
    out = []
    for p in preds:
        r = declaration.rows[p.column - k]
        e = by_key.get((r.source, r.quantity))
        q = inverse(r.transform, np.array(p.quantiles)) if r.judged else [math.nan] * 3
        f = fitted[p.column]
        loo = f.loo
        out.append(
            {
                "chapter": e.chapter if e is not None else "",
                "source": r.source,
                "quantity": r.quantity,
                "unit": r.unit,
                "published": r.published,
                "asserts": _asserts(r),
                "fold": p.fold,
                "conditioning folds": fold_rows[p.fold][0],
                "common targets": fold_rows[p.fold][1],
                "NROY fraction": p.nroy_fraction,
                "p2.5": q[0],
                "p50": q[1],
                "p97.5": q[2],
                "implausibility": p.implausibility,
                "PIT": p.pit,
                "verdict": p.verdict,
                "twin of": e.twin if e is not None and e.twin else "",
                "driven by": texts[p.column],
                "runs": f.runs,
                "LOO Q²": loo.q2 if loo else math.nan,
                "LOO 95 % coverage": loo.coverage95 if loo else math.nan,
                "LOO beyond 3": loo.fraction_beyond if loo else math.nan,
                "not emulable because": f.reason if p.verdict == NOT_EMULABLE else "",
            }
        )
    return pd.DataFrame(out)


def _asserts(r) -> str:
    if not r.judged:
        return ""
    low, high = (float(inverse(r.transform, np.array(v))) for v in (r.low, r.high))
    if r.low == r.high:
        return f"value {r.published:g}"
    if math.isinf(r.low) or (r.transform == "log" and low == 0):
        return f"≤ {high:.4g}"
    return f"≥ {low:.4g}"


def emulator_table(
    ens: Ensemble, fitted: Sequence[Fitted], ids: Sequence[str], var: np.ndarray, df: np.ndarray
) -> pd.DataFrame:
    """Every column's emulator: runs, active inputs, nugget, the replicates' variance and its
    degrees of freedom, the leave-one-out diagnostics, emulable or why not."""
    out = []
    for name, f, v, n in zip(ens.names, fitted, var, df):
        e = f.emulator
        out.append(
            {
                "column": name,
                "runs": f.runs,
                "active inputs": ", ".join(ids[i] for i in e.active) if e is not None else "",
                "nugget": e.nugget if e is not None else math.nan,
                "replicates' variance": v,
                "replicates' df": int(n),
                "LOO Q²": f.loo.q2 if f.loo else math.nan,
                "LOO 95 % coverage": f.loo.coverage95 if f.loo else math.nan,
                "LOO beyond 3": f.loo.fraction_beyond if f.loo else math.nan,
                "emulable": e is not None,
                "why not": "" if e is not None else f.reason,
            }
        )
    return pd.DataFrame(out)


def coverage_table(ens: Ensemble, chosen: np.ndarray, cov: Coverage, test: str) -> pd.DataFrame:
    """One row per pseudo-thesis under ``test`` (its bench, :func:`benches`): its member, the
    held-out rows with an interval, the share inside the 95 % one."""
    counted = ~np.isnan(cov.inside)
    return pd.DataFrame(
        {
            "test": test,
            MEMBER: [ens.members[i] for i in chosen],
            "held-out rows": counted.sum(axis=1) if len(chosen) else [],
            "inside 95 %": np.nansum(cov.inside, axis=1) if len(chosen) else [],
        }
    )


def pit_table(ens: Ensemble, chosen: np.ndarray, cov: Coverage, test: str) -> pd.DataFrame:
    """Every held-out row of every pseudo-thesis with an interval under ``test``: its PIT and
    whether its printed value lies inside its 95 % interval."""
    out = []
    for j, i in enumerate(chosen):
        for c in np.flatnonzero(~np.isnan(cov.inside[j])):
            out.append(
                {
                    "test": test,
                    MEMBER: ens.members[i],
                    "column": ens.names[c],
                    "PIT": cov.pit[j, c],
                    "inside 95 %": bool(cov.inside[j, c]),
                }
            )
    return pd.DataFrame(out, columns=["test", MEMBER, "column", "PIT", "inside 95 %"])


def findings(verdicts: pd.DataFrame) -> pd.DataFrame:
    """The verdicts' findings: a row with its algebraic twins (a % of stroke, an adjusted R²,
    whose ``twin of`` names it) is one."""
    return verdicts[verdicts["twin of"].astype(object).fillna("") == ""]


def counts(verdicts: pd.DataFrame) -> dict[str, int]:
    """The verdicts counted as findings (:func:`findings`)."""
    own = findings(verdicts)
    found = own["verdict"].value_counts()
    return {v: int(found.get(v, 0)) for v in VERDICTS} | {"findings": len(own)}


def failures(rows: pd.DataFrame) -> dict[str, str]:
    """{member: the step that failed} of the runs whose analysis failed (rows.csv's
    :data:`~selfsense.envelope.campaign.FAILED_COLUMN`; a table made before it had none)."""
    if FAILED_COLUMN not in rows:
        return {}
    reasons = rows[FAILED_COLUMN].astype(object).fillna("").astype(str)
    return {m: r for m, r in zip(rows[MEMBER], reasons) if r}


def summary(declaration, ens, verdicts, fitted, cut, folds, table, covs, df, failed) -> str:
    """The validation's opening (reStructuredText); ``covs``: {test: the pseudo-theses'
    coverage}, the headline last; ``failed``: {member: the step that failed}."""
    n = counts(verdicts)
    k = len(declaration.targets)
    emulable = [f.emulator is not None for f in fitted]
    waves = ", ".join(
        f"wave {w}: {r} runs, {100 * f:.3g} % of the prior left"
        for w, r, f in zip(sorted(set(ens.wave)), cut.runs, cut.fractions)
    )
    steps = sorted({r.split(" (", 1)[0] for r in failed.values()})
    lines = [
        f"Validation of {declaration.dataset} under workflow/validation.yaml version "
        f"{declaration.version} ({declaration.date}): {len(ens.members)} runs "
        f"(noise measured with {int(np.max(df, initial=0))} degrees of freedom); {waves}.",
        "",
        f"Runs whose analysis failed: {len(failed)}"
        + (
            f" (in {', '.join(steps)}; they give no value, so neither rule out nor condition)"
            if failed
            else ""
        )
        + ".",
        "",
        f"Emulable: {sum(emulable[:k])} of {k} common targets, {sum(emulable[k:])} of "
        f"{len(emulable) - k} emergent rows.",
        "",
        f"Findings: {n['findings']} (a twin counted with its row): "
        + "; ".join(f"{v}: {n[v]}" for v in VERDICTS)
        + ".",
    ]
    for test, cov in reversed(covs.items()):
        low, high = (min(max(b, 0.0), 1.0) for b in binomial_band(max(cov.judged, 1)))
        lines += [
            "",
            f"Pseudo-theses, {test}: {len(cov.inside)}, {cov.judged} held-out rows with an "
            f"interval, coverage at the nominal "
            f"{declaration.settings['pseudo_theses']['nominal']:.0%}: "
            + (
                f"{cov.coverage:.1%} (± 3 binomial sd: {low:.1%}–{high:.1%})"
                if cov.judged
                else "none"
            )
            + f"; {cov.incompatible} left some fold no region. PIT histogram (tenths): "
            + " ".join(str(int(c)) for c in cov.histogram)
            + ".",
        ]
    incompatible = verdicts[verdicts["verdict"] == INCOMPATIBLE]["fold"].unique()
    lines += [
        "",
        "Incompatible folds (the others leave no bench): "
        + (", ".join(incompatible) if len(incompatible) else "none")
        + ".",
    ]
    alone = [f for i, f in enumerate(folds) if table[i, i] == 0.0]
    pairs = [
        f"{a}–{b}"
        for i, a in enumerate(folds)
        for j, b in enumerate(folds)
        if j > i and table[i, j] == 0.0 and table[i, i] > 0 and table[j, j] > 0
    ]
    lines += [
        "",
        "Folds the common targets leave no region: " + (", ".join(alone) or "none") + ".",
        "Pairs of folds that cannot hold together: " + (", ".join(pairs) or "none") + ".",
    ]
    out = verdicts[verdicts["verdict"] == INCONSISTENT]
    if len(out):
        lines += [
            "",
            "Inconsistent rows (fold, least implausibility of the published value, drivers):",
            "",
        ]
        lines += [
            f"- {r['source']}, {r['quantity']}: published {r['published']:.4g}, predicted "
            f"{r['p2.5']:.4g} … {r['p97.5']:.4g} {r['unit']} ({r['fold']}, I = "
            f"{r['implausibility']:.3g}; {r['driven by'] or 'no drivers'})"
            for _, r in out.iterrows()
        ]
    lines += ["", "Not emulable (leave-one-out: Q², 95 % coverage, share beyond 3):", ""]
    failed = [(name, f) for name, f in zip(ens.names, fitted) if f.emulator is None]
    failed = [(name, f) for name, f in failed if f.reason != "no verdict in the registry"]
    lines += [
        f"- {name}: {f.reason}"
        + (
            f" (Q² {f.loo.q2:.2f}, {f.loo.coverage95:.0%}, {f.loo.fraction_beyond:.0%})"
            if f.loo
            else ""
        )
        for name, f in failed
    ] or ["- none"]
    return "\n".join(lines) + "\n"
