"""History matching with known truth: on an analytic simulator with noise, whose not-ruled-out
region for the given observations is known in closed form, the waves' emulators recover it on a
dense grid (agreement, and every disagreement explained by the emulator's own variance); the
implausibility, the second-maximum rule and the designs do what their equations say."""

import numpy as np
import pytest

from selfsense.envelope.emulator import Settings
from selfsense.envelope.history_matching import (
    cut_rank,
    ensemble_variance,
    implausibility,
    maximin_latin_hypercube,
    maximin_subset,
    not_ruled_out,
    nuggets,
    run_waves,
    screen,
)

NOISE = np.array([0.04, 0.04, 0.03])  # the simulator's seed noise (sd) per output
OBS_MD = np.array([0.03, 0.03, 0.02]) ** 2  # declared observation + discrepancy variance
TRUTH = np.array([0.35, 0.6])


def expected(X):
    """The simulator's expectation: three smooth outputs of two inputs."""
    x1, x2 = X[:, 0], X[:, 1]
    return np.column_stack([2 * x1 + x2, np.sin(3 * x2) + x1**2, np.exp(x1 * x2)])


def simulate(X, seeds):
    noise = np.stack([np.random.default_rng(int(s)).standard_normal(3) for s in seeds])
    return expected(X) + noise * NOISE


def grid(n=120):
    g = (np.arange(n) + 0.5) / n
    return np.array(np.meshgrid(g, g)).reshape(2, -1).T


@pytest.fixture(scope="module")
def matching():
    z = expected(TRUTH[None, :])[0]
    return run_waves(
        simulate,
        2,
        z,
        z,
        OBS_MD,
        cutoff=3.0,
        second_maximum_from=10,
        first_runs=30,
        later_runs=20,
        replicate_points=10,
        replicate_seeds=4,
        candidates=4096,
        max_waves=3,
        shrink_below=0.2,
        seed=20261201,
        settings=Settings(restarts=1, seed=0),
    )


def test_the_waves_recover_the_known_not_ruled_out_region(matching):
    X = grid()
    z = expected(TRUTH[None, :])[0]
    V = NOISE**2 + OBS_MD
    distance = np.abs(expected(X) - z)
    true_nroy = np.all(distance <= 3 * np.sqrt(V), axis=1)  # 3 targets: the maximum is cut
    found = matching.not_ruled_out(X)
    assert 0.02 < true_nroy.mean() < 0.3  # a real cut, neither everything nor nothing
    assert found[np.argmin(np.sum((X - TRUTH) ** 2, axis=1))]  # the truth is kept
    # Where may the method disagree with the closed form? Its denominator is V̂ + Var_em, with
    # V̂ from each wave's nugget (fitted within the replicates' 99 % interval, 30 degrees of
    # freedom) and Var_em the emulators' own, and its mean is off by the emulators'
    # error (within 3 of their sd). So an output's boundary may move between
    # 3√min(V, V̂) − 3 sd_em and 3√(max(V, V̂) + Var_em) + 3 sd_em, and a point may be
    # misclassified only where that band leaves it undecided: no output surely beyond its
    # boundary, and not every output surely within. Each wave's emulators cut, so the band is
    # the widest over the waves.
    waves = matching.waves
    var = np.max([np.column_stack([e.predict(X)[1] for e in w.emulators]) for w in waves], axis=0)
    V_hat = [nuggets(w.emulators) + OBS_MD for w in waves]
    low = 3 * np.sqrt(np.minimum(V, np.min(V_hat, axis=0))) - 3 * np.sqrt(var)
    high = 3 * np.sqrt(np.maximum(V, np.max(V_hat, axis=0)) + var) + 3 * np.sqrt(var)
    surely_out = np.any(distance > high, axis=1)
    surely_in = np.all(distance < low, axis=1)
    undecided = ~surely_out & ~surely_in
    wrong = found != true_nroy
    assert not np.any(wrong & ~undecided)
    # the undecided band is narrow beside the region, and the agreement on the grid high
    assert undecided.sum() < 1.5 * true_nroy.sum()
    assert np.mean(~wrong) > 0.95
    assert np.median(np.sqrt(var[true_nroy]), axis=0).max() < NOISE.min()


def test_the_waves_refocus_inside_the_region(matching):
    assert len(matching.waves) >= 2
    fractions = [w.nroy_fraction for w in matching.waves]
    assert fractions == sorted(fractions, reverse=True)
    later = matching.waves[1].design
    # a later wave's runs lie where the earlier waves left the region open
    first = matching.waves[0]
    kept = screen(
        first.emulators,
        later,
        matching.z_low,
        matching.z_high,
        matching.var_obs_md,
        3.0,
        10,
    )
    assert kept.all()
    # Var_ens is the seed's noise, measured by the replicates (30 degrees of freedom: the sd's
    # estimate is within ±40 % at 3 sd) and refined by the nugget on every run
    assert np.sqrt(matching.replicate_var) == pytest.approx(NOISE, rel=0.4)
    assert np.sqrt(matching.var_ens) == pytest.approx(NOISE, rel=0.3)


def test_the_implausibility_of_values_and_bounds():
    z = np.array([1.0, -np.inf, 0.0])
    zh = np.array([1.0, 2.0, np.inf])
    mean = np.array([[1.3, 2.5, -0.4], [0.7, 1.0, 0.2]])
    var_em = np.array([[0.03, 0.0, 0.0], [0.0, 0.0, 0.0]])
    other = np.array([0.06, 0.25, 0.04])
    I = implausibility(z, zh, mean, var_em, other)
    assert I[0] == pytest.approx([0.3 / 0.3, 0.5 / 0.5, 0.4 / 0.2])
    assert I[1] == pytest.approx([0.3 / np.sqrt(0.06), 0.0, 0.0])  # within the bounds: 0


def test_the_second_maximum_rule():
    I = np.array([[5.0, 1.0, 1.0], [5.0, 4.0, 1.0], [2.0, 2.9, 1.0]])
    assert cut_rank(9, 10) == 1 and cut_rank(10, 10) == 2
    assert list(not_ruled_out(I, 3.0, second_maximum_from=10)) == [False, False, True]
    assert list(not_ruled_out(I, 3.0, second_maximum_from=3)) == [True, False, True]
    # a target not emulable (NaN) is absent, not zero: it neither rules out nor counts
    J = np.array([[np.nan, 5.0], [np.nan, 1.0]])
    assert list(not_ruled_out(J, 3.0, 2)) == [False, True]


def test_the_designs_fill_the_space():
    design = maximin_latin_hypercube(20, 3, seed=1, candidates=30)
    assert design.shape == (20, 3) and design.min() >= 0 and design.max() <= 1
    strata = np.floor(design * 20).astype(int)
    assert all(sorted(strata[:, k]) == list(range(20)) for k in range(3))  # a Latin hypercube
    from scipy.spatial.distance import pdist
    from scipy.stats import qmc

    one = qmc.LatinHypercube(d=3, seed=np.random.default_rng(1)).random(20)
    assert pdist(design).min() >= pdist(one).min()
    points = np.random.default_rng(2).random((500, 2))
    subset = maximin_subset(points, 10, seed=3, candidates=50)
    assert len(subset) == 10 and pdist(subset).min() > 0.05


def test_the_ensemble_variance_pools_the_replicates():
    rng = np.random.default_rng(4)
    reps = 3.0 + rng.standard_normal((40, 5, 2)) * np.array([0.5, 2.0])
    reps[:, :, 1] += np.arange(40)[:, None]  # the point's own level is not noise
    assert np.sqrt(ensemble_variance(reps)) == pytest.approx([0.5, 2.0], rel=0.1)
