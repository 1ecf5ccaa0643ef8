"""The method's own test with known truth: on an analytic multi-output simulator with seed
noise, 24 pseudo-theses (members drawn from the prior, taken as the bench, printed to two
decimals) go through the same emulators and leave-one-fold-out; their held-out rows' coverage at
the nominal 95 % lands in 90–99 %, and the PIT histogram is not far from flat. A method whose
predictive leaves out the seed's variance fails the same test. With a declared discrepancy
larger than the noise, benches that are the twin itself are covered more often than 99 %, and
only benches that carry a discrepancy drawn as declared are covered at the nominal rate."""

from dataclasses import replace

import numpy as np
import pytest

from selfsense.envelope.coverage import (
    DISCREPANT,
    EXACT,
    benches,
    binomial_band,
    printed,
    pseudo_theses,
)
from selfsense.envelope.emulator import Settings
from selfsense.envelope.fold_prediction import COMMON, Columns
from selfsense.envelope.history_matching import (
    emulate,
    ensemble_variance,
    maximin_latin_hypercube,
    nuggets,
    predict_all,
    prior_candidates,
)

NOISE = 0.05  # the seed's noise (sd) on every output
DIGIT = 0.01  # the pseudo-theses print two decimals
MD = 0.01  # a declared discrepancy sd (the pseudo-theses have none: a little over-coverage)
FOLDS = np.array([COMMON, COMMON, "A", "A", "B", "B", "C", "C", "D"], dtype=object)


def expected(X):
    x1, x2, x3 = X.T
    return np.column_stack(
        [
            x1 + x2,  # common targets
            x3,
            np.sin(2 * x1),  # fold A
            x1 * x2 + x3,
            x2**2,  # fold B
            x2 - 0.5 * x3,
            np.cos(x1 + x3),  # fold C
            x1 - x2,
            x1 * x3 + x2,  # fold D
        ]
    )


def simulate(X, rng):
    return expected(X) + NOISE * rng.standard_normal((len(X), len(FOLDS)))


@pytest.fixture(scope="module")
def setting():
    rng = np.random.default_rng(20261202)
    X = maximin_latin_hypercube(45, 3, seed=1, candidates=10)
    Y = simulate(X, rng)
    reps = np.stack([Y[:8], *[simulate(X[:8], rng) for _ in range(3)]], axis=1)
    X_all, Y_all = (
        np.vstack([X, X[:8], X[:8], X[:8]]),
        np.vstack([Y, *reps[:, 1:].transpose(1, 0, 2)]),
    )
    emulators, diagnostics = emulate(
        X_all, Y_all, Settings(restarts=0), ensemble_variance(reps), 24
    )
    assert all(d.emulable for d in diagnostics)
    cands = prior_candidates(2048, 3, seed=2)
    mean, var_em = predict_all(emulators, cands)
    k = len(FOLDS)
    columns = Columns(
        fold=FOLDS,
        z_low=np.zeros(k),
        z_high=np.zeros(k),
        var_obs_md=np.full(k, DIGIT**2 / 12 + MD**2),
        band_low=np.full(k, -np.inf),
        band_high=np.full(k, np.inf),
        judged=np.ones(k, bool),
        condition=np.ones(k, bool),
        left_out={},
    )
    members = prior_candidates(24, 3, seed=3)  # the pseudo-benches, drawn from the prior
    truths = printed(simulate(members, rng), ["identity"] * k, np.full(k, DIGIT))
    return columns, mean, var_em, nuggets(emulators), truths


def test_the_pseudo_theses_coverage_is_near_nominal(setting):
    columns, mean, var_em, var_ens, truths = setting
    result = pseudo_theses(
        columns, mean, var_em, var_ens, truths, cutoff=3.0, second_maximum_from=10
    )
    assert result.judged == 24 * 7  # every held-out row of every pseudo-thesis had a region
    assert result.incompatible == 0
    # 168 rows at 95 %: the binomial sd is 1.7 %, and rows of a fold move together, so 90–99 %
    # is ±3 sd below and +2.4 sd above (the discrepancy the pseudo-theses lack widens a little)
    low, high = binomial_band(result.judged)
    assert low < 0.90 and high > 0.99
    assert 0.90 <= result.coverage <= 0.99
    # the PIT histogram: no decile empty or holding over a quarter of the rows
    assert result.histogram.sum() == result.judged
    assert result.histogram.min() > 0 and result.histogram.max() < 0.25 * result.judged


def test_a_predictive_without_the_seeds_variance_fails_the_same_test(setting):
    columns, mean, var_em, var_ens, truths = setting
    result = pseudo_theses(
        columns, mean, var_em, np.zeros_like(var_ens), truths, cutoff=3.0, second_maximum_from=10
    )
    assert result.coverage < 0.90


def test_only_a_bench_that_carries_the_declared_discrepancy_is_covered_at_the_nominal(setting):
    columns, mean, var_em, var_ens, _ = setting
    md = 0.15  # three times the noise: the predictive is mostly discrepancy
    k = len(FOLDS)
    wide = replace(columns, var_obs_md=np.full(k, DIGIT**2 / 12 + md**2))
    values = simulate(prior_candidates(24, 3, seed=3), np.random.default_rng(7))
    coverage = {
        test: pseudo_theses(
            wide,
            mean,
            var_em,
            var_ens,
            printed(bench, ["identity"] * k, np.full(k, DIGIT)),
            cutoff=3.0,
            second_maximum_from=10,
        ).coverage
        for test, bench in benches(values, np.full(k, md), {"seed": 5}).items()
    }
    assert coverage[EXACT] > 0.99
    assert 0.90 <= coverage[DISCREPANT] <= 0.99


def test_a_bench_with_no_discrepancy_declared_is_the_twin_alone():
    values = np.arange(6.0).reshape(2, 3)
    assert list(benches(values, np.ones(3), None)) == [EXACT]
    drawn = benches(values, np.array([0.0, 1.0, 2.0]), {"seed": 1})
    assert drawn[DISCREPANT][:, 0] == pytest.approx(values[:, 0])  # sd 0: no draw
    assert np.all(drawn[DISCREPANT][:, 1:] != values[:, 1:])
    again = benches(values, np.array([0.0, 1.0, 2.0]), {"seed": 1})[DISCREPANT]
    np.testing.assert_array_equal(again, drawn[DISCREPANT])


def test_printing_rounds_on_the_quantitys_own_scale():
    values = np.log(np.array([[1.234, 0.05678]]))
    out = printed(values, ["log", "log"], np.array([0.01, 0.001]))
    assert np.exp(out[0]) == pytest.approx([1.23, 0.057])
    r2 = printed(np.log1p(-np.array([[0.998894]])), ["log1m"], np.array([1e-5]))
    assert -np.expm1(r2[0]) == pytest.approx([0.99889])
