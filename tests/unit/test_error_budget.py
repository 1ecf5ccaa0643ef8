"""The observer's error budget (selfsense.verify.error_budget): each source lands where it belongs
and the sources add up to the error. On the smoke DAG the total is Table 5.4's:
tests/workflow/test_verify_tables.py."""

import re

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from selfsense.methods.observer import HPOGains, HybridPositionObserver
from selfsense.verify.error_budget import (
    AT_MAX_SPREAD,
    CHARGE_SOURCES,
    SOURCES,
    BudgetStats,
    SpanBudgets,
    Superposition,
    charge_position_budget,
)
from selfsense.verify.truth import TRUTH_STATES, Truth

from ..tolerances import CLOSED_FORM, rtol

FS = 48_000.0
GAINS = HPOGains(17.0, 2 * np.pi, 1.0)
N = int(1.5 * FS)
t = np.arange(N) / FS


def observer():
    return HybridPositionObserver(GAINS, FS)


def recursion_tol(scale):
    """Roundings of the observer's recursion add up to ≈ ε/(1 − ρ) of the signals' size, ρ the
    spectral radius of its Ad (1/(1 − ρ) ≈ 7600 samples at 48 kHz), as in test_observer."""
    rho = np.max(np.abs(np.linalg.eigvals(observer().discrete.Ad)))
    return rtol(1.0 / (1.0 - rho)) * scale


def trapezoid(current):
    """The charge the Tustin observer integrates from a current, starting from zero (its x_I·a0)."""
    return np.cumsum(current + np.concatenate([[0.0], current[:-1]])) / (2 * FS)


def bench(**faults):
    """A perfect bench driven at 10 Hz (15 µm): every signal agrees with the true position, except
    the ``faults`` given as {input: what is added to it} (arrays over the N samples)."""
    current = GAINS.a0 * 15e-6 * 2 * np.pi * 10 * np.sin(2 * np.pi * 10 * t)
    x = trapezoid(current) / GAINS.a0  # the true x is exactly what the charge path integrates
    signals = {
        "current": current,
        "x_cp": x,
        "x_laser": x,
        "x": x,
        "x_charge": x,
        "x_capacitance": x,
        "offset": np.zeros(N),
    }
    for name, fault in faults.items():
        signals[name] = signals[name] + fault
    return signals


def split(signals, chunks=1):
    paths = Superposition(observer())
    parts = [
        paths.split(**{k: v[sl] for k, v in signals.items()})
        for sl in np.array_split(np.arange(N), chunks)
    ]
    return {s: np.concatenate([p[s] for p in parts]) for s in SOURCES}


def direct_error(signals):
    """x̂ − x_laser of one observer fed what the chain feeds its own."""
    return observer().step(signals["current"], signals["x_cp"]) - signals["x_laser"]


rng = np.random.default_rng(18)
OFFSET = 1e-3 + 2e-5 * np.sin(2 * np.pi * 0.05 * t)  # 1 mA with a slow drift, as the twin's probe
NOISE = 5e-3 * rng.standard_normal(N)
LASER = 0.1e-6 * rng.standard_normal(N) + 0.3e-6 * np.sin(2 * np.pi * 0.2 * t)
LAG = np.concatenate([np.zeros(48), bench()["x"][:-48]]) - bench()["x"]  # x_CP 1 ms late
GAMMA_ERROR = 0.2e-6 * np.cos(2 * np.pi * 10 * t) ** 2
# a 300 Hz q–x error of 0.5 µm, with the current that carries exactly that charge
HYSTERESIS_CURRENT = GAINS.a0 * 0.5e-6 * 2 * np.pi * 300 * np.cos(2 * np.pi * 300 * t)
HYSTERESIS = trapezoid(HYSTERESIS_CURRENT) / GAINS.a0

CASES = {  # source: the one fault that makes it
    "probe offset": {"current": OFFSET, "offset": OFFSET},
    "current noise": {"current": NOISE},
    "q–x map": {"x_charge": HYSTERESIS, "current": HYSTERESIS_CURRENT},
    "C_e estimate": {"x_cp": LAG},
    "Γ map": {"x_capacitance": GAMMA_ERROR, "x_cp": GAMMA_ERROR},
    "laser": {"x_laser": LASER},
}


@pytest.mark.parametrize("source", SOURCES)
def test_a_single_fault_lands_in_its_own_source_only(source):
    signals = bench(**CASES[source])
    parts = split(signals)
    scale = max(np.max(np.abs(v)) for k, v in signals.items() if k not in ("current", "offset"))
    tol = recursion_tol(scale)
    others = {s: float(np.max(np.abs(parts[s]))) for s in SOURCES if s != source}
    assert max(others.values()) <= tol, others
    assert np.max(np.abs(parts[source])) > 1e3 * tol
    if source == "laser":
        np.testing.assert_allclose(parts["laser"], -LASER, rtol=0, atol=tol)
    np.testing.assert_allclose(sum(parts.values()), direct_error(signals), rtol=0, atol=tol)


def test_an_offset_step_leaves_the_analytic_response_of_eq_5_7():
    """x̂/I0 = s/(a0 (s + ωS)²) at ζS = 1: a step I0 leaves I0·t·e^(−ωS t)/a0."""
    offset = np.full(N, 1e-3)
    parts = split(bench(current=offset, offset=offset))
    # the trapezoid integrates a step from sample 0 as if it began half a sample earlier
    shifted = t + 0.5 / FS
    analytic = 1e-3 * shifted * np.exp(-GAINS.omega_s * shifted) / GAINS.a0
    # beyond that, the trapezoid and Tustin's warping are second order: (ωS/fs)² = 1.7e-8 of the
    # size
    err = np.max(np.abs(parts["probe offset"] - analytic)) / np.max(analytic)
    assert err < 10 * (GAINS.omega_s / FS) ** 2


def test_a_low_frequency_gamma_error_passes_whole_and_a_fast_hysteresis_of_q_too():
    """Below ωS, H_CP ≈ 1 passes the Γ map's error; far above it, H_I ≈ 1 passes the q–x map's."""
    late = t > 1.0  # after H_CP's start from zero
    gamma = split(bench(x_capacitance=np.full(N, 0.2e-6), x_cp=np.full(N, 0.2e-6)))["Γ map"]
    assert np.max(np.abs(gamma[late] - 0.2e-6)) < 0.01 * 0.2e-6
    charge = split(bench(**CASES["q–x map"]))["q–x map"]
    assert (
        np.max(np.abs(charge[late] - HYSTERESIS[late])) < 0.05 * 0.5e-6
    )  # |H_I − 1| ≈ 2ζωS/ω at 300 Hz


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), chunks=st.integers(1, 7))
def test_the_sources_add_up_to_the_error_for_any_signals(seed, chunks):
    """Arbitrary, mutually inconsistent inputs: the sum is exact by linearity alone, and chunking
    changes nothing."""
    r = np.random.default_rng(seed)
    walk = lambda scale: scale * np.cumsum(r.standard_normal(N)) / np.sqrt(N)  # noqa: E731
    signals = {
        "current": 1e-3 * r.standard_normal(N) + walk(1e-2),
        "offset": walk(1e-3),
        **{k: walk(30e-6) for k in ("x_cp", "x_laser", "x", "x_charge", "x_capacitance")},
    }
    parts = split(signals, chunks)
    x_i = np.max(np.abs(trapezoid(signals["current"]))) / GAINS.a0
    scale = max(
        x_i, *(np.max(np.abs(v)) for k, v in signals.items() if k not in ("current", "offset"))
    )
    np.testing.assert_allclose(
        sum(parts.values()), direct_error(signals), rtol=0, atol=recursion_tol(scale)
    )
    whole = split(signals)
    for s in SOURCES:
        np.testing.assert_array_equal(parts[s], whole[s])


def test_the_stats_report_the_sources_at_the_instant_of_the_max_and_shares_with_cross_terms():
    e = np.array([1.0, -3.0, 2.0]) * 1e-6
    parts = dict.fromkeys(SOURCES, np.zeros(3)) | {"laser": e / 2, "probe offset": e / 2}
    stats = BudgetStats()
    stats.add(np.arange(3.0), e, parts, np.array([True, True, True]))
    row = stats.row()
    assert row["total max error [µm]"] == pytest.approx(3.0) and row[
        "total at max [µm]"
    ] == pytest.approx(-3.0)
    assert row["laser at total max [µm]"] == pytest.approx(-1.5) and row["time of max [s]"] == 1.0
    assert row["laser share of mean square"] == pytest.approx(0.25)
    assert row["cross terms share of mean square"] == pytest.approx(0.5)  # two equal halves: 2·(½)²
    assert row["max |sum of sources − total| [µm]"] == 0.0


def test_spans_of_one_label_are_counted_together_and_their_spread_over_tests_split():
    """Two segments, each in three tests; chunks cut across the spans. A segment's row is over all
    its tests; its σ over the tests is Table 6.1's (ddof = 1) of the tests' maxima, and of the
    sources at each test's max; a label with no samples has no row."""
    t = np.arange(60.0)
    tests = (
        np.repeat([1.0, 2.0, 4.0, 1.0, 1.0, 1.0], 10) * 1e-6
    )  # a's tests: 1, 2, 4 µm; b's: 1 µm each
    parts = dict.fromkeys(SOURCES, np.zeros(60)) | {"laser": tests / 4, "Γ map": 3 * tests / 4}
    spans = [
        ("a", 0, 10),
        ("a", 10, 20),
        ("a", 20, 30),
        ("b", 30, 40),
        ("b", 40, 50),
        ("b", 50, 60),
        ("c", 70, 80),
    ]
    budgets = SpanBudgets(spans)
    for cut in (slice(0, 25), slice(25, 60)):
        budgets.add(t[cut], tests[cut], {k: v[cut] for k, v in parts.items()})
    rows = budgets.rows()
    assert list(rows) == ["a", "b"] and rows["a"]["samples"] == 30 and rows["a"]["tests"] == 3
    assert rows["a"]["total max error [µm]"] == pytest.approx(4.0)
    assert rows["a"]["total max σ over tests [µm]"] == pytest.approx(np.std([1, 2, 4], ddof=1))
    assert rows["a"]["Γ map at max σ over tests [µm]"] == pytest.approx(
        0.75 * np.std([1, 2, 4], ddof=1)
    )
    assert rows["a"]["laser at max σ over tests [µm]"] == pytest.approx(
        0.25 * np.std([1, 2, 4], ddof=1)
    )
    assert rows["b"]["total max σ over tests [µm]"] == 0.0
    assert [c for c in rows["a"] if c.endswith(AT_MAX_SPREAD)] == [
        s + AT_MAX_SPREAD for s in SOURCES
    ]  # sources only


def test_truth_interpolation_is_aligned_to_the_stored_samples_and_exact_for_cubics():
    decimation, n = 12, 1200
    k = np.arange(0, n, decimation)
    cubic = lambda i: 1e-6 * ((i / n) ** 3 - 2 * (i / n) ** 2 + 0.5)  # noqa: E731
    truth = Truth({s: cubic(k) for s in TRUTH_STATES}, decimation, n)
    inner = np.arange(decimation, n - 2 * decimation)  # the ends use the nearest values
    np.testing.assert_allclose(truth.at(inner)["x"], cubic(inner), rtol=1e-12)
    assert np.array_equal(truth.at(k)["q"], cubic(k))


@pytest.mark.parametrize(
    "states, n, problem",
    [
        ({s: np.zeros(10) for s in TRUTH_STATES if s != "C_e"}, 120, "lacks the state(s) C_e"),
        ({s: np.zeros(10) for s in TRUTH_STATES}, 121, "has 10 values, the capture's 121 samples"),
        ({s: np.full(10, np.nan) for s in TRUTH_STATES}, 120, "non-finite"),
    ],
)
def test_bad_truth_fails_with_one_line_naming_the_file(states, n, problem):
    with pytest.raises(ValueError, match=re.escape(problem)) as err:
        Truth(states, 12, n, "raw/x/run.nc")
    assert str(err.value).startswith("raw/x/run.nc: ") and "\n" not in str(err.value)
    with pytest.raises(ValueError, match="no decimation attribute"):
        Truth.from_group({}, states, n, "raw/x/run.nc")


def test_a_means_truth_is_the_mean_over_its_samples():
    """A cubic in the sample index is reproduced exactly by the 4-point cubic between the stored
    values, so each window's mean is the cubic's mean over the window's samples."""
    decimation, ns, n = 12, 12, 1200
    k = np.arange(n, dtype=float)
    cubic = 1e-6 * (1 + 3e-3 * k - 2e-6 * k**2 + 1e-9 * k**3)
    truth = Truth({s: cubic[::decimation] for s in TRUTH_STATES}, decimation, n)
    last = np.arange(
        2 * ns - 1, n - 2 * decimation, ns
    )  # clear of the ends, which hold the nearest value
    got = truth.means(last, ns)
    expected = np.array([cubic[i - ns + 1 : i + 1].mean() for i in last])
    assert np.allclose(
        got["x"], expected, rtol=CLOSED_FORM, atol=0
    )  # four weights ≤ 1, terms of one size
    assert set(got) == set(TRUTH_STATES)


@pytest.mark.parametrize("loop_um", [0.0, 0.3])
def test_the_charge_position_error_splits_into_current_path_q_x_map_and_laser(loop_um):
    """q = a0·(x + a q–x loop term), the probe's offset integrated (q0 + I_0·t, which the fit
    removes) and a laser 10 nm off, read from its first sample. Without a loop the fit is exact and
    every source is zero; with one the q–x map holds it (the offset fit takes a little of it into
    the current path)."""
    fs, block = 48_000.0, 48
    n = block * 400
    k = np.arange(n)
    x = 15e-6 * (1 - np.cos(2 * np.pi * 10 * k / fs))
    q = 17.0 * (x + loop_um * 1e-6 * np.sin(2 * np.pi * 10 * k / fs))
    truth = Truth({"x": x, "q": q}, 1, n, names=("x", "q"))
    last = np.arange(block - 1, n, block)
    means = truth.means(last, block)
    series = {
        "time": (last - (block - 1) / 2) / fs,
        "x_laser": means["x"] + 10e-9,
        "q": means["q"] + 1e-9 + 2e-9 * (last / fs),
    }
    row = charge_position_budget(series, truth, fs, block)
    assert row["max |sum of sources − total| [µm]"] <= 1e-9
    assert row["laser max [µm]"] < 1e-6  # its offset is gone with its zero
    if (
        loop_um == 0.0
    ):  # κ of the fit's 3-column least squares ≈ 1e4 on these scales: far below 1 pm
        assert row["q–x map max [µm]"] < 1e-6 and row["current path max [µm]"] < 1e-6
    else:
        assert 0.2 < row["q–x map max [µm]"] < 0.4
        assert row["q–x map rms [µm]"] > 3 * row["current path rms [µm]"]
    assert [
        c.removesuffix(" rms [µm]")
        for c in row
        if c.endswith(" rms [µm]") and c != "total rms [µm]"
    ] == list(CHARGE_SOURCES)
