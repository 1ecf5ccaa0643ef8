"""The validation's emulators on known functions: a smooth function is emulable and predicted at
new points within its own variance; an output rough in the inputs (white noise in x), one that is
all seed noise, and a function with jumps closer than the runs are flagged "not emulable" by the
leave-one-out diagnostics; the closed-form leave-one-out errors equal refits without the run;
the emulator's variance is the process's without its nugget; the active inputs are the ones that
move the output."""

import numpy as np
import pytest
from scipy.stats import qmc
from sklearn.gaussian_process import GaussianProcessRegressor

from selfsense.envelope.emulator import (
    Settings,
    active_inputs,
    diagnose,
    fit,
    leave_one_out,
    sobol_shares,
)

SETTINGS = Settings(restarts=1, seed=0)
N, D = 40, 3


def design(seed=0, n=N, d=D):
    return qmc.LatinHypercube(d=d, seed=seed).random(n)


def smooth(X):
    return np.sin(3 * X[:, 0]) + X[:, 1] ** 2


@pytest.mark.parametrize("seed", [0, 1])
def test_a_smooth_function_is_emulable_and_predicted_within_its_variance(seed):
    X = design(seed)
    emulator = fit(X, smooth(X), SETTINGS, noise_var=0.0)
    loo = leave_one_out(emulator, SETTINGS)
    assert loo.emulable, loo.reason
    assert loo.q2 > 0.95
    new = design(seed + 10, n=200)
    mean, var = emulator.predict(new)
    z = (smooth(new) - mean) / np.sqrt(var + 1e-12)
    assert np.max(np.abs(smooth(new) - mean)) < 0.1  # the function spans ≈ 2
    assert np.mean(np.abs(z) < 3) > 0.95


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_an_output_rough_in_the_inputs_is_not_emulable(seed):
    X = design(seed)
    y = np.random.default_rng(seed).standard_normal(N)  # white noise in x: no seed noise
    loo = leave_one_out(fit(X, y, SETTINGS, noise_var=0.0), SETTINGS)
    assert not loo.emulable and "Q²" in loo.reason


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_an_output_that_is_all_seed_noise_is_not_emulable(seed):
    X = design(seed)
    y = 0.2 * np.random.default_rng(seed).standard_normal(N)  # the replicates measure 0.2²
    loo = leave_one_out(fit(X, y, SETTINGS, noise_var=0.04), SETTINGS)
    assert not loo.emulable and "Q²" in loo.reason


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_jumps_closer_than_the_runs_are_not_emulable(seed):
    X = design(seed)
    # a checkerboard of squares π/16 ≈ 0.2 wide, about the runs' spacing (1/√40 in the 2 inputs)
    y = np.sign(np.sin(16 * X[:, 0]) * np.sin(16 * X[:, 1]))
    loo = leave_one_out(fit(X, y, SETTINGS, noise_var=0.0), SETTINGS)
    assert not loo.emulable


def test_a_smooth_function_with_seed_noise_stays_emulable():
    X = design(3)
    y = smooth(X) + 0.1 * np.random.default_rng(3).standard_normal(N)
    emulator = fit(X, y, SETTINGS, noise_var=0.01)
    loo = leave_one_out(emulator, SETTINGS)
    assert loo.emulable, loo.reason
    assert emulator.nugget == pytest.approx(0.01)


def test_the_closed_form_leave_one_out_is_the_refit_without_the_run():
    X = design(4)
    y = smooth(X) + 0.05 * np.random.default_rng(4).standard_normal(N)
    emulator = fit(X, y, SETTINGS)
    loo = leave_one_out(emulator, SETTINGS)
    X_train, r = emulator.X_train, emulator.residuals  # about the linear mean, held
    for i in (0, 7, 23):
        keep = np.arange(N) != i
        refit = GaussianProcessRegressor(emulator.gp.kernel_, optimizer=None, alpha=1e-10)
        refit.fit(X_train[keep], r[keep])
        mu, sd = refit.predict(X_train[i : i + 1], return_std=True)  # nugget included
        assert loo.errors[i] == pytest.approx((r[i] - mu[0]) / sd[0], rel=1e-5)


def test_the_emulators_variance_holds_the_mean_and_leaves_out_the_nugget():
    # A noisy linear output: the process has little to add, and what the emulator does not know
    # is the linear mean's coefficients. Its variance must cover its error against the true
    # function (without the coefficients' uncertainty it claims far too little), and stay below
    # the variance of a new noisy run (the nugget is the ensemble's, not the function's).
    errors = []
    for seed in range(4):
        X = design(20 + seed, n=30)
        truth = 2 * X[:, 0] - X[:, 1]
        y = truth + 0.1 * np.random.default_rng(seed).standard_normal(len(X))
        emulator = fit(X, y, SETTINGS, noise_var=0.01)
        new = design(40 + seed, n=50)
        mean, var = emulator.predict(new)
        assert np.all(var < 0.01)
        errors.append((2 * new[:, 0] - new[:, 1] - mean) / np.sqrt(var))
    errors = np.concatenate(errors)
    assert 0.6 < np.std(errors) < 1.6
    assert np.mean(np.abs(errors) < 3) > 0.97


def test_the_active_inputs_are_those_that_move_the_output():
    X = design(7, n=60, d=6)
    y = 3 * X[:, 4] + np.sin(4 * X[:, 1]) + 0.01 * X[:, 2]
    assert list(active_inputs(X, y, max_active=12, min_index=0.02)) == [1, 4]
    assert list(active_inputs(X, y, max_active=1, min_index=0.02)) == [4]


def test_the_diagnosis_of_standardised_errors():
    rng = np.random.default_rng(8)
    good = rng.standard_normal(400)
    assert diagnose(good, 0.9, SETTINGS).emulable
    wide = diagnose(2.5 * good, 0.9, SETTINGS)  # an emulator that claims too little variance
    assert not wide.emulable and "beyond 3" in wide.reason and "coverage" in wide.reason
    assert not diagnose(good, 0.3, SETTINGS).emulable


def test_the_sobol_shares_of_an_additive_function_are_its_variance_shares():
    """y = 4 x₃ + 2 x₇² + sin 3x₁₁ + ε over 30 unknowns: each term's share of Var y is its own
    variance over the total (16/12, 4 · 4/45, Var sin 3x, and ε's 0.01 for the noise), every
    other unknown's 0. The estimator's sampling sd at a base of 1024 is below 0.001 here (20
    seeds of the scrambled Sobol' points); what is left is the emulator's error from 150 runs with
    noise of sd 0.1, about 0.005 a share: the tolerance, 0.02, is four times it."""
    rng = np.random.default_rng(0)
    d = 30
    X = design(3, n=150, d=d)
    y = 4 * X[:, 3] + 2 * X[:, 7] ** 2 + np.sin(3 * X[:, 11]) + rng.normal(0, 0.1, len(X))
    emulator = fit(X, y, SETTINGS, noise_var=0.01)
    shares, noise = sobol_shares(emulator, d, 1024, seed=1)
    grid = np.linspace(0.0, 1.0, 200001)
    parts = np.array([16 / 12, 16 / 45, np.var(np.sin(3 * grid))])
    total = parts.sum() + 0.01
    assert shares[[3, 7, 11]] == pytest.approx(parts / total, abs=0.02)
    assert noise == pytest.approx(0.01 / total, abs=0.01)
    others = np.setdiff1d(np.arange(d), emulator.active)
    assert np.all(shares[others] == 0.0)
    assert np.all(shares >= 0.0) and shares.sum() + noise <= 1.0 + 0.02


def test_an_output_that_is_all_noise_is_driven_by_the_noise():
    X = design(4, n=60, d=5)
    y = np.random.default_rng(1).normal(0.0, 1.0, len(X))
    emulator = fit(X, y, SETTINGS, noise_var=1.0)
    shares, noise = sobol_shares(emulator, 5, 256, seed=1)
    assert noise > 0.8
    assert shares.sum() < 0.2
