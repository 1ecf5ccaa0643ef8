"""Every fold predicted from the others, on an analytic simulator whose emulators are exact: a
held-out row's published value never changes its own prediction, only its verdict (and it does
change the other folds'); folds that demand different benches are incompatible, and a fold
conditioned on both has no region; the verdicts follow the predictive interval and the row's
band; the shipped declaration gives the columns the method reads."""

import numpy as np
import pytest

from selfsense.envelope.fold_prediction import (
    COMMON,
    CONSISTENT,
    INCOMPATIBLE,
    INCONSISTENT,
    NO_VERDICT,
    NOT_EMULABLE,
    UNINFORMATIVE,
    Columns,
    compatibility,
    declared_columns,
    mixture_cdf,
    mixture_quantiles,
    predict_folds,
)
from selfsense.envelope.validation import load_validation

from ..helpers import ROOT

POINTS = np.random.default_rng(0).random((4000, 2))  # prior candidates, unit cube
TRUTH = np.array([0.3, 0.7])
SD = 0.05  # every column's Var_ens + Var_obs + Var_md, as one sd


def outputs(X):
    """Columns: a common target, fold A's two rows, fold B's row, fold C's row."""
    x1, x2 = X[:, 0], X[:, 1]
    return np.column_stack([x1 + x2, x1, 2 * x1 - x2, x2, x1 * x2])


FOLDS = np.array([COMMON, "A", "A", "B", "C"], dtype=object)


def columns(z=None, judged=None):
    z = outputs(TRUTH[None, :])[0] if z is None else np.asarray(z, dtype=float)
    k = len(z)
    return Columns(
        fold=FOLDS,
        z_low=z.copy(),
        z_high=z.copy(),
        var_obs_md=np.full(k, SD**2 / 2),
        band_low=z - 0.5,
        band_high=z + 0.5,
        judged=np.ones(k, bool) if judged is None else judged,
        condition=np.ones(k, bool),
        left_out={},
    )


def predict(cols, mean=None):
    mean = outputs(POINTS) if mean is None else mean
    var_em = np.full_like(mean, 1e-6)
    return predict_folds(
        cols,
        mean,
        var_em,
        np.full(mean.shape[1], SD**2 / 2 - 1e-6),
        cutoff=3.0,
        second_maximum_from=10,
    )


def test_a_rows_published_value_changes_its_verdict_not_its_prediction():
    before = {p.column: p for p in predict(columns())}
    z = outputs(TRUTH[None, :])[0]
    z[1] += 0.6  # fold A's first row, published far from the truth
    after = {p.column: p for p in predict(columns(z))}
    assert before[1].verdict == CONSISTENT and after[1].verdict == INCONSISTENT
    for c in (1, 2):  # fold A's rows: their own prediction is the same to the bit
        assert after[c].quantiles == before[c].quantiles
        assert after[c].nroy_fraction == before[c].nroy_fraction
    assert after[1].implausibility > 3 > before[1].implausibility
    # the other folds are conditioned on it, so theirs move (the test could fail)
    assert after[3].quantiles != before[3].quantiles
    assert after[4].quantiles != before[4].quantiles


def test_the_prediction_brackets_the_truth_and_narrows_with_conditioning():
    preds = {p.column: p for p in predict(columns())}
    truth = outputs(TRUTH[None, :])[0]
    for c in (1, 2, 3, 4):
        lo, mid, hi = preds[c].quantiles
        assert lo < truth[c] < hi
        assert 0.1 < preds[c].pit < 0.9
    # fold C (x1·x2) is predicted from the common target and folds A and B, which pin x1 and x2
    lo, _, hi = preds[4].quantiles
    assert hi - lo < 0.5 * np.ptp(outputs(POINTS)[:, 4])


def test_folds_that_demand_different_benches_are_incompatible():
    z = outputs(TRUTH[None, :])[0]
    z[3] = 0.05  # fold B asks x2 ≈ 0.05, while A (with the common target) asks x2 ≈ 0.7
    preds = {p.column: p for p in predict(columns(z))}
    assert preds[4].verdict == INCOMPATIBLE and preds[4].nroy_fraction == 0.0
    assert np.isnan(preds[4].quantiles[0])
    folds, table = compatibility(
        columns(z),
        outputs(POINTS),
        np.full((len(POINTS), 5), 1e-6),
        np.full(5, SD**2 / 2 - 1e-6),
        cutoff=3.0,
        second_maximum_from=10,
    )
    at = {f: i for i, f in enumerate(folds)}
    assert table[at["A"], at["B"]] == 0.0 == table[at["B"], at["A"]]
    assert table[at["A"], at["C"]] > 0 and table[at["A"], at["A"]] > 0
    assert table[at["B"], at["B"]] > 0  # alone with the common target B holds: x1 ≈ 0.95
    assert table[at["C"], at["C"]] > table[at["A"], at["C"]]


def test_the_verdicts_of_bounds_unjudged_and_not_emulable_rows():
    z = outputs(TRUTH[None, :])[0]
    cols = columns(z, judged=np.array([True, True, True, True, False]))
    cols.z_low[3], cols.z_high[3] = -np.inf, 0.0  # fold B: "x2 below 0", far below the truth
    mean = outputs(POINTS)
    mean[:, 2] = np.nan  # fold A's second row: not emulable
    preds = {p.column: p for p in predict(cols, mean)}
    assert preds[4].verdict == NO_VERDICT
    assert preds[2].verdict == NOT_EMULABLE
    assert preds[3].verdict == INCONSISTENT and np.isnan(preds[3].pit)
    cols.z_high[3] = 2.0  # "x2 below 2": consistent, and a bound is never uninformative
    assert {p.column: p for p in predict(cols, mean)}[3].verdict == CONSISTENT
    # a point row whose interval is wider than its own band is uninformative
    wide = columns(z)
    wide.band_low[1], wide.band_high[1] = z[1] - 0.01, z[1] + 0.01
    assert {p.column: p for p in predict(wide)}[1].verdict == UNINFORMATIVE


def test_the_mixtures_quantiles_invert_its_cdf():
    rng = np.random.default_rng(1)
    mean, sd = rng.normal(size=300), rng.uniform(0.1, 0.5, 300)
    q = mixture_quantiles(mean, sd, [0.025, 0.5, 0.975])
    assert [mixture_cdf(mean, sd, t) for t in q] == pytest.approx([0.025, 0.5, 0.975], abs=1e-9)
    one = mixture_quantiles(np.zeros(1), np.ones(1), [0.975])
    assert one[0] == pytest.approx(1.959964, abs=1e-5)


def test_the_declared_columns():
    declaration = load_validation(ROOT / "workflow" / "validation.yaml")
    cols = declared_columns(declaration)
    assert len(cols.fold) == len(declaration.targets) + 206
    assert cols.folds[0] == "F01" and len(cols.folds) == 17
    p1 = [declaration.targets[i].id for i in cols.left_out["F10"]]
    assert sorted(p1) == ["p1_loop_works", "p1_no_limit_cycle"]
    assert int(np.sum(~cols.judged)) == 24  # the registry's no-verdict coefficients
    assert np.all(cols.var_obs_md[cols.judged] > 0)
