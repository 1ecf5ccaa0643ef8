"""Tests for selfsense.methods.gamma (thesis Eq 5.4 / 7.13, Tables 5.1, 5.2, 7.2, 7.3)."""

import numpy as np
import pandas as pd
import pytest
import statsmodels.api as sm
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.polynomial import polynomial as P
from scipy import stats

from selfsense.methods.gamma import (
    anova_table,
    coefficient_table,
    fit_gamma,
    fit_log_gamma,
    gamma_t_table,
    model_selection_table,
)

from ..tolerances import CLOSED_FORM, rtol, sums

# Table 5.2 (j = 5, x in µm, C in µF): x decreases from ≈ 33 µm at 2.16 µF to ≈ 0 at 3.13 µF.
B_TABLE_5_2 = np.array([-4560.5, 8773.922, -6589.93, 2445.475, -450.855, 33.10029])
# Table 7.3 (n = 5 with T): b_T0..b_T5 and g [µm/°C].
B_TABLE_7_3 = np.array([-870.776, 1639.54, -1132.54, 376.6851, -61.8409, 4.036799])
G_TABLE_7_3 = 0.263115
C_RANGE_UF = (2.16, 3.13)  # Table 4.2: C_P100 … C_P0


def _cubic_truth() -> np.ndarray:
    """Power coefficients (µm, µF) of x = 33 (0.5 s + 0.3 s² + 0.2 s³), s = (3.2 − C) / 1.1."""
    s = P.Polynomial([3.2 / 1.1, -1 / 1.1])
    return P.Polynomial([0.0, 16.5, 9.9, 6.6])(s).coef


def _capacitance_uf(n: int, rng: np.random.Generator) -> np.ndarray:
    """C sampled along a sinusoidal stroke, as in the 0.1 Hz fitting data (dense at the ends)."""
    lo, hi = C_RANGE_UF
    phase = rng.uniform(0, 2 * np.pi, n)
    return lo + (hi - lo) * 0.5 * (1 - np.cos(phase))


def _thesis_like(coef, n=3000, noise_um=0.4, seed=0):
    """(C [F], x [m], C [µF], x [µm]) with x = Σ coef_i C^i + noise, thesis units inside."""
    rng = np.random.default_rng(seed)
    c_uf = _capacitance_uf(n, rng)
    x_um = P.polyval(c_uf, coef) + rng.normal(0, noise_um, n)
    return c_uf * 1e-6, x_um * 1e-6, c_uf, x_um


def _thesis_like_t(n=8000, noise_um=0.39, g_ct=0.0, seed=0):
    """Γ_T data: (C [F], x [m], T [°C], C [µF], x [µm]); T heats 23 → 60 °C over the record."""
    rng = np.random.default_rng(seed)
    c_uf = _capacitance_uf(n, rng)
    t = 23 + 37 * (1 - np.exp(-np.linspace(0, 4, n))) + rng.normal(0, 0.3, n)
    x_um = (
        P.polyval(c_uf, B_TABLE_7_3)
        + G_TABLE_7_3 * t
        + g_ct * c_uf * t
        + rng.normal(0, noise_um, n)
    )
    return c_uf * 1e-6, x_um * 1e-6, t, c_uf, x_um


def _raw_ols(c_uf, x_um, order, t=None, interaction=False):
    """Independent reference: statsmodels OLS on the raw power-basis design."""
    cols = [np.vander(c_uf, order + 1, increasing=True)]
    if t is not None:
        cols.append(t[:, None])
    if interaction:
        cols.append((c_uf * t)[:, None])
    return sm.OLS(x_um, np.hstack(cols)).fit()


# --- coefficient recovery -------------------------------------------------------------


@pytest.mark.parametrize("basis", ["scaled", "raw"])
@pytest.mark.parametrize("coef", [_cubic_truth(), B_TABLE_5_2], ids=["cubic", "table5.2"])
def test_recovers_polynomial_exactly_without_noise(coef, basis):
    c, x, *_ = _thesis_like(coef, n=500, noise_um=0.0)
    fit = fit_gamma(c, x, order=coef.size - 1, basis=basis)
    np.testing.assert_allclose(fit.coefficients.to_numpy(), coef, rtol=1e-7)
    assert list(fit.coefficients.index) == [f"b{i}" for i in range(coef.size)]
    assert fit.max_residual_um < 1e-8


@pytest.mark.parametrize("coef", [_cubic_truth(), B_TABLE_5_2], ids=["cubic", "table5.2"])
def test_recovers_polynomial_from_noisy_data(coef):
    c, x, c_uf, x_um = _thesis_like(coef, n=14375, noise_um=0.4, seed=1)
    fit = fit_gamma(c, x, order=coef.size - 1)
    table = coefficient_table(fit)
    z = (table["Coefficients"] - coef) / table["Standard Error"]
    assert np.all(np.abs(z) < 4)
    assert np.all((table["Lower 95%"] < coef) | (np.abs(z) > 1.96))
    # standard errors match an independent raw-basis fit, so the test above has teeth
    np.testing.assert_allclose(
        table["Standard Error"], _raw_ols(c_uf, x_um, coef.size - 1).bse, rtol=1e-6
    )
    assert fit.std_error_um == pytest.approx(0.4, rel=0.03)


def test_log_model_recovers_a_and_b():
    rng = np.random.default_rng(2)
    c_uf = _capacitance_uf(400, rng)
    x_um = 97.0 - 85.0 * np.log(c_uf)
    fit = fit_log_gamma(c_uf * 1e-6, x_um * 1e-6)
    assert list(fit.coefficients.index) == ["a", "b"]
    # exact data: least squares returns them to cond(design)·ε (cond < 100, asserted below)
    np.testing.assert_allclose(
        fit.coefficients.to_numpy(), [97.0, -85.0], rtol=rtol(fit.condition_number)
    )
    np.testing.assert_allclose(
        fit.predict(2.5e-6), (97.0 - 85.0 * np.log(2.5)) * 1e-6, rtol=rtol(fit.condition_number)
    )
    assert fit.condition_number < 100


# --- ANOVA and coefficient tables -----------------------------------------------------


@pytest.mark.parametrize(
    ("n", "order", "with_t", "dfs"),
    [(14375, 5, False, (5, 14369, 14374)), (8000, 5, True, (6, 7993, 7999))],
    ids=["table5.2", "table7.3"],
)
def test_anova_identities(n, order, with_t, dfs):
    if with_t:
        c, x, t, c_uf, x_um = _thesis_like_t(n=n)
    else:
        (c, x, c_uf, x_um), t = _thesis_like(B_TABLE_5_2, n=n), None
    fit = fit_gamma(c, x, order, temperature=t)
    a = anova_table(fit)
    assert list(a.index) == ["Regression", "Residual", "Total"]
    assert list(a.columns) == ["df", "SS", "MS", "F", "Significance F"]
    assert tuple(a["df"]) == dfs  # the df columns printed in Tables 5.2 / 7.3

    fitted = fit.predict(c, t) * 1e6  # independent of the table code
    ss_tot = np.sum((x_um - x_um.mean()) ** 2)
    ss_res = np.sum((x_um - fitted) ** 2)
    ss_reg = np.sum((fitted - x_um.mean()) ** 2)
    # n-term sums of squares; the residual x − fitted cancels |x|/|r| of its digits
    kappa = np.max(np.abs(x_um)) / np.sqrt(ss_res / x_um.size)
    np.testing.assert_allclose(a["SS"], [ss_reg, ss_res, ss_tot], rtol=sums(x_um.size) * kappa)
    ss = a["SS"]
    assert ss["Regression"] + ss["Residual"] == pytest.approx(
        ss["Total"], rel=sums(x_um.size) * kappa
    )
    np.testing.assert_allclose(
        a["MS"].iloc[:2], a["SS"].iloc[:2] / a["df"].iloc[:2], rtol=CLOSED_FORM
    )
    f_stat = a.loc["Regression", "MS"] / a.loc["Residual", "MS"]
    assert a.loc["Regression", "F"] == pytest.approx(f_stat, rel=CLOSED_FORM)
    assert a.loc["Regression", "Significance F"] == pytest.approx(
        stats.f.sf(f_stat, *dfs[:2]), abs=1e-300
    )
    assert fit.r2 == pytest.approx(ss_reg / ss_tot, rel=sums(x_um.size) * kappa)
    assert fit.r2_adj == pytest.approx(
        1 - (ss_res / dfs[1]) / (ss_tot / dfs[2]), rel=sums(x_um.size) * kappa
    )
    assert fit.std_error_um == pytest.approx(np.sqrt(ss_res / dfs[1]), rel=sums(x_um.size) * kappa)
    assert a[["MS", "F", "Significance F"]].loc["Total"].isna().all()

    ref = _raw_ols(c_uf, x_um, order, t)
    # the reference solves the raw power basis: accurate only to cond(raw)·ε of |x|, over |r|
    raw_kappa = fit.condition_number * kappa
    assert fit.r2 == pytest.approx(ref.rsquared, rel=rtol(raw_kappa))
    assert a.loc["Regression", "F"] == pytest.approx(ref.fvalue, rel=rtol(raw_kappa))
    assert a.loc["Residual", "SS"] == pytest.approx(ref.ssr, rel=rtol(raw_kappa))


@pytest.mark.parametrize("interaction", [False, True])
def test_coefficient_table(interaction):
    c, x, t, c_uf, x_um = _thesis_like_t(n=3000, g_ct=0.03 * interaction)
    fit = fit_gamma(c, x, 5, temperature=t, interaction=interaction)
    table = coefficient_table(fit)
    names = [f"b{i}" for i in range(6)] + ["g"] + ["g_CT"] * interaction
    assert list(table.index) == names
    assert list(table.columns) == [
        "Coefficients",
        "Standard Error",
        "t Stat",
        "P-value",
        "Lower 95%",
        "Upper 95%",
    ]
    coef, se, tstat = table["Coefficients"], table["Standard Error"], table["t Stat"]
    df = fit.results.df_resid
    np.testing.assert_allclose(tstat, coef / se, rtol=CLOSED_FORM)
    # the t distribution's tail is relatively accurate to ~1e-14 (scipy's incomplete beta) but a
    # p-value amplifies an error in t by |t|·f(t)/sf(t) ≈ t² for large |t|
    kappa_p = 1 + np.asarray(tstat, float) ** 2
    np.testing.assert_allclose(
        table["P-value"],
        2 * stats.t.sf(np.abs(tstat), df),
        rtol=rtol(kappa_p.max(), 100),
        atol=1e-300,
    )
    half = stats.t.ppf(0.975, df) * se
    # coef ± half cancels when the interval straddles zero: κ = (|coef| + half)/|coef ± half|
    np.testing.assert_allclose(
        table["Lower 95%"],
        coef - half,
        rtol=CLOSED_FORM * np.max((np.abs(coef) + half) / np.abs(coef - half)),
    )
    np.testing.assert_allclose(
        table["Upper 95%"],
        coef + half,
        rtol=CLOSED_FORM * np.max((np.abs(coef) + half) / np.abs(coef + half)),
    )

    ref = _raw_ols(c_uf, x_um, 5, t, interaction)
    np.testing.assert_allclose(coef, ref.params, rtol=1e-6)
    np.testing.assert_allclose(se, ref.bse, rtol=1e-6)
    np.testing.assert_allclose(table["P-value"], ref.pvalues, rtol=1e-5, atol=1e-300)


# --- basis: scaled vs raw -------------------------------------------------------------


@pytest.mark.parametrize("order", [3, 4, 5, 6])
def test_scaled_basis_matches_raw_basis(order):
    c, x, c_uf, _ = _thesis_like(B_TABLE_5_2, n=14375)
    scaled = fit_gamma(c, x, order)
    raw = fit_gamma(c, x, order, basis="raw")
    np.testing.assert_allclose(scaled.fitted_um, raw.fitted_um, rtol=0, atol=1e-7)
    np.testing.assert_allclose(scaled.coefficients, raw.coefficients, rtol=1e-6)
    # the raw basis's fitted values are good to cond·ε of |x|; its sums of squares, relative to
    # the residual's: κ = cond·max|x|/rms(r)
    kappa = (
        raw.condition_number
        * np.max(np.abs(raw.fitted_um))
        / np.sqrt(raw.results.ssr / raw.results.nobs)
    )
    pd.testing.assert_frame_equal(anova_table(scaled), anova_table(raw), rtol=float(rtol(kappa)))

    expected_raw_cond = np.linalg.cond(np.vander(c_uf, order + 1, increasing=True))
    # both are the ratio of extreme singular values of one matrix: SVD is backward stable, and
    # the smallest singular value is relatively accurate to cond·ε
    assert scaled.condition_number == pytest.approx(
        expected_raw_cond, rel=float(rtol(scaled.condition_number))
    )
    assert raw.condition_number == scaled.condition_number
    assert scaled.condition_number > 10**order  # raw power basis: ill-conditioned
    assert scaled.condition_number_scaled < 10  # Legendre on the scaled domain


def test_raw_condition_number_grows_with_order():
    c, x, *_ = _thesis_like(B_TABLE_5_2)
    conds = [fit_gamma(c, x, j).condition_number for j in (3, 4, 5, 6)]
    assert np.all(np.diff(np.log10(conds)) > 1)


@settings(max_examples=60, deadline=None)
@given(
    order=st.integers(1, 6),
    coef=st.lists(st.floats(-50, 50), min_size=7, max_size=7),
    lo=st.floats(1.5, 3.0),
    width=st.floats(0.5, 1.5),
    n=st.integers(20, 300),
    noise=st.floats(0.0, 2.0),
    seed=st.integers(0, 2**32 - 1),
)
def test_fitted_values_invariant_to_basis(order, coef, lo, width, n, noise, seed):
    rng = np.random.default_rng(seed)
    # one point at random in each of n equal bins, as a sweep of C_e covers its range: uniform
    # draws can leave a gap at an end, which the order-6 fit's condition number then feels
    c_uf = lo + width * (np.arange(n) + rng.uniform(0, 1, n)) / n
    u = (c_uf - lo) / width  # keep x of moderate size for any random coefficients
    x_um = P.polyval(u, coef[: order + 1]) + rng.normal(0, noise, n)
    scaled = fit_gamma(c_uf * 1e-6, x_um * 1e-6, order)
    raw = fit_gamma(c_uf * 1e-6, x_um * 1e-6, order, basis="raw")
    # the raw-basis solution is only accurate to ~ eps · cond(raw design) relative to |x|
    tol = 100 * np.finfo(float).eps * raw.condition_number * (1 + np.max(np.abs(x_um)))
    np.testing.assert_allclose(scaled.fitted_um, raw.fitted_um, rtol=0, atol=tol)
    c_new = rng.uniform(lo, lo + width, 10) * 1e-6
    np.testing.assert_allclose(
        scaled.predict(c_new) * 1e6, raw.predict(c_new) * 1e6, rtol=0, atol=tol
    )
    ssr_tol = 2 * tol * np.sqrt(n * raw.results.ssr) + n * tol**2
    assert scaled.results.ssr == pytest.approx(raw.results.ssr, abs=ssr_tol)
    # Legendre P_0..P_m on the data's range: the continuous Gram matrix is diag(1/(2k + 1)), so the
    # design's condition number tends to √(2m + 1) (3.6 at m = 6); twice that allows for 20 points
    # (the worst of 3000 seeds at m = 6, n = 20: 4.25)
    assert scaled.condition_number_scaled < 2 * np.sqrt(2 * order + 1)


# --- predict: SI at the edge ----------------------------------------------------------


def test_predict_is_si_and_matches_raw_coefficients():
    c, x, t, c_uf, _ = _thesis_like_t(n=2000)
    fit = fit_gamma(c, x, 5, temperature=t)
    # same design matrix and coefficients: a few roundings of |x| ≤ 40 µm
    np.testing.assert_allclose(
        fit.predict(c, t), fit.fitted_um * 1e-6, rtol=0, atol=CLOSED_FORM * 40e-6
    )
    b = fit.coefficients
    by_hand_um = P.polyval(2.5, b[[f"b{i}" for i in range(6)]].to_numpy()) + b["g"] * 40.0
    # by hand in the raw power basis: good to cond(raw)·ε of the terms' size
    assert fit.predict(2.5e-6, 40.0) == pytest.approx(
        by_hand_um * 1e-6, rel=float(rtol(fit.condition_number))
    )
    assert fit.predict(np.full((2, 3), 2.5e-6), 40.0).shape == (2, 3)


# --- Γ_T ------------------------------------------------------------------------------


def test_gamma_t_recovers_g():
    c, x, t, *_ = _thesis_like_t(seed=3)
    table = coefficient_table(fit_gamma(c, x, 5, temperature=t))
    g, se = table.loc["g", ["Coefficients", "Standard Error"]]
    assert abs(g - G_TABLE_7_3) < 4 * se
    assert se < 0.01


def test_interaction_p_value_large_without_and_tiny_with_interaction():
    c, x, t, *_ = _thesis_like_t(seed=4)
    fit = fit_gamma(c, x, 5, temperature=t, interaction=True)
    assert coefficient_table(fit).loc["g_CT", "P-value"] > 0.05

    c, x, t, *_ = _thesis_like_t(seed=4, g_ct=0.03)
    table = coefficient_table(fit_gamma(c, x, 5, temperature=t, interaction=True))
    assert table.loc["g_CT", "P-value"] < 1e-10
    assert abs(table.loc["g_CT", "Coefficients"] - 0.03) < 4 * table.loc["g_CT", "Standard Error"]


def test_gamma_t_table_layout():
    c, x, t, *_ = _thesis_like_t(n=3000, g_ct=0.03)
    table = gamma_t_table(c, x, t)
    assert list(table["model"]) == ["n=4", "n=5", "n=6", "n=5 + C·T"]
    assert list(table.columns) == [
        "model",
        "R²",
        "adjusted R²",
        "standard error [µm]",
        "interaction p-value",
    ]
    assert table["interaction p-value"].iloc[:3].isna().all()
    inter = fit_gamma(c, x, 5, temperature=t, interaction=True)
    last = table.iloc[3]
    assert last["interaction p-value"] == coefficient_table(inter).loc["g_CT", "P-value"]
    assert (last["R²"], last["standard error [µm]"]) == (inter.r2, inter.std_error_um)
    n5 = fit_gamma(c, x, 5, temperature=t)
    assert table.iloc[1][["R²", "adjusted R²"]].tolist() == [n5.r2, n5.r2_adj]


def test_model_selection_table_layout():
    c, x, *_ = _thesis_like(B_TABLE_5_2, noise_um=0.4)
    table = model_selection_table(c, x)
    assert list(table["model"]) == ["j=3", "j=4", "j=5", "j=6", "ln"]
    assert list(table.columns) == ["model", "max residual [µm]", "R²", "adjusted R²"]
    assert np.all(np.diff(table["R²"].iloc[:4]) >= -1e-12)  # nested models
    j5 = fit_gamma(c, x, 5)
    assert table.iloc[2][["max residual [µm]", "R²", "adjusted R²"]].tolist() == [
        j5.max_residual_um,
        j5.r2,
        j5.r2_adj,
    ]
    assert table.iloc[4]["R²"] == fit_log_gamma(c, x).r2
    assert list(model_selection_table(c, x, orders=(5,), include_log=False)["model"]) == ["j=5"]


# --- validation -----------------------------------------------------------------------

_C = np.linspace(2.2e-6, 3.1e-6, 20)
_X = np.linspace(30e-6, 1e-6, 20)
_T = 23 + 37 * np.sin(np.linspace(0, 3, 20)) ** 2  # not collinear with C


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"C": _C[:-1]}, "same length"),
        ({"x": np.r_[_X[:-1], np.nan]}, "x contains NaN"),
        ({"C": np.r_[np.nan, _C[1:]]}, "C contains NaN"),
        ({"temperature": np.r_[_T[:-1], np.inf]}, "temperature contains NaN"),
        ({"temperature": _T[:-1]}, "same length"),
        ({"C": _C[:6], "x": _X[:6]}, "6 coefficients need more than 6 points, got 6"),
        (
            {"C": _C[:7], "x": _X[:7], "temperature": _T[:7]},
            "7 coefficients need more than 7 points",
        ),
        ({"order": 0}, "order must be an integer"),
        ({"order": 2.5}, "order must be an integer"),
        ({"interaction": True}, "needs a temperature"),
        ({"basis": "legendre"}, "basis must be one of"),
        ({"C": -_C}, "C must be positive"),
        ({"C": np.r_[_C[:5], np.full(15, _C[5])], "order": 6}, "rank 6 < 7 coefficients"),
        ({"temperature": 23 + 1e6 * _C}, "rank 6 < 7 coefficients"),
        ({"temperature": np.full(20, 23.0)}, "temperature is constant"),
        ({"C": _C.reshape(4, 5)}, "C must be one-dimensional"),
    ],
)
def test_fit_gamma_validation(kwargs, match):
    args = {"C": _C, "x": _X, "order": 5} | kwargs
    with pytest.raises(ValueError, match=match):
        fit_gamma(**args)


def test_enough_points_is_accepted():
    assert fit_gamma(_C[:7], _X[:7], 5).results.df_resid == 1


def test_log_model_validation():
    with pytest.raises(ValueError, match="same length"):
        fit_log_gamma(_C, _X[:-1])


def test_predict_validation():
    plain = fit_gamma(_C, _X, 3)
    with_t = fit_gamma(_C, _X, 3, temperature=_T)
    with pytest.raises(ValueError, match="takes no temperature"):
        plain.predict(_C, _T)
    with pytest.raises(ValueError, match="requires a temperature"):
        with_t.predict(_C)
    with pytest.raises(ValueError, match="C contains NaN"):
        plain.predict([2.5e-6, np.nan])
