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

from selfsense.envelope.emulator import Settings, active_inputs, diagnose, fit, leave_one_out

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
    y = np.sign(np.sin(8 * X[:, 0]) * np.sin(8 * X[:, 1]))  # a checkerboard of 1/8 squares
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
    gp = emulator.gp
    for i in (0, 7, 23):
        keep = np.arange(N) != i
        refit = GaussianProcessRegressor(gp.kernel_, optimizer=None, alpha=gp.alpha)
        refit.fit(gp.X_train_[keep], gp.y_train_[keep])
        mu, sd = refit.predict(gp.X_train_[i : i + 1], return_std=True)  # nugget included
        assert loo.errors[i] == pytest.approx((gp.y_train_[i] - mu[0]) / sd[0], rel=1e-6)


def test_the_emulators_variance_leaves_out_the_nugget():
    X = design(5)
    y = smooth(X) + 0.1 * np.random.default_rng(5).standard_normal(N)
    emulator = fit(X, y, SETTINGS)
    new = design(6, n=20)
    mean, var = emulator.predict(new)
    _, sd = emulator.gp.predict(new[:, emulator.active], return_std=True)
    total = sd**2 * emulator.scale**2
    assert var == pytest.approx(total - emulator.nugget, rel=1e-6, abs=1e-12)
    assert np.all(var < total)


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
