"""Capacitance-based position self-sensing: the fitting functions Γ and Γ_T.

Thesis (Islam 2013) Eq 5.4 maps the measured effective capacitance C of the stack to
its position x with a polynomial of order j,

    Γ:   x = b0 + Σ_{i=1..j} b_i C^i,

fitted on 0.1 Hz data (Tables 5.1, 5.2); Eq 7.13 adds a linear temperature term,

    Γ_T: x = b0 + Σ_{i=1..j} b_i C^i + g T        (optionally + g_CT C T),

fitted on 50 Hz data (Tables 7.2, 7.3).  Table 5.1 also lists a log model
x = a + b ln C.

Units.  Every public function takes SI inputs (C in F, x in m, T in °C) and
``GammaFit.predict`` returns x in m.  Inside, the regression runs in the thesis's units
(C in µF, x in µm), so coefficients, residuals, standard errors and every table are in
those units, directly comparable with the thesis.  The conversion happens only at the
edge (``_UF_PER_F``, ``_UM_PER_M``).

Numerics.  The raw power basis 1, C, ..., C^j over C ≈ 2.1-3.2 µF is badly conditioned
(condition number ~1e4 for j = 3 up to ~1e9 for j = 6).  By default the least-squares
problem is therefore solved in a well-conditioned basis: Legendre polynomials of
u = (C - C_mid) / C_half, which maps the data range onto [-1, 1] (and temperature scaled
the same way).  Fitted values, residuals and all sums of squares are basis-invariant and
come from that fit.  The raw power-basis coefficients the thesis reports are an exact
linear map M of the scaled-basis ones (b = M β), so their standard errors, t statistics,
p-values and confidence intervals follow from statsmodels' ``t_test`` with M as the
contrast matrix, i.e. Cov(b) = M Cov(β) Mᵀ.  ``basis="raw"`` fits the raw design
directly (what Excel does), for comparison.

The ANOVA is Excel's Data Analysis layout (Regression / Residual / Total), not a
sequential per-term ANOVA such as ``statsmodels.stats.anova_lm`` produces.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING, Literal

import numpy as np
from numpy.polynomial import Legendre, Polynomial
from numpy.typing import ArrayLike

if TYPE_CHECKING:  # pandas where the tables are made: ≈ 0.3 s of the streaming jobs' start-up
    import pandas as pd
    import statsmodels.api as sm

__all__ = [
    "GammaFit",
    "GammaPolynomial",
    "load_gamma",
    "fit_gamma",
    "fit_log_gamma",
    "anova_table",
    "coefficient_table",
    "model_selection_table",
    "gamma_t_table",
]

_UF_PER_F = 1e6  # thesis capacitance unit: µF
_UM_PER_M = 1e6  # thesis position unit: µm

Basis = Literal["scaled", "raw"]
_BASES = ("scaled", "raw")


@dataclass(frozen=True)
class _Design:
    """How (C [µF], T [°C]) become regressors, in either basis.

    Term k of the raw basis is z^i · T^m for the exponent pair ``terms[k] = (i, m)``,
    where z = C (polynomial Γ) or z = ln C (log model).  In the scaled basis the same
    term is P_i(u) · P_m(v), with P Legendre polynomials and u, v the feature and the
    temperature mapped from their data ranges onto [-1, 1].  Both bases span the same
    column space, so they give the same least-squares fit.
    """

    order: int
    log: bool
    z_domain: tuple[float, float]
    t_domain: tuple[float, float] | None
    interaction: bool
    basis: Basis

    @property
    def terms(self) -> tuple[tuple[int, int], ...]:
        terms = [(i, 0) for i in range(self.order + 1)]
        if self.t_domain is not None:
            terms.append((0, 1))
            if self.interaction:
                terms.append((1, 1))
        return tuple(terms)

    @property
    def names(self) -> tuple[str, ...]:
        names = {(0, 1): "g", (1, 1): "g_CT"}
        if self.log:
            names |= {(0, 0): "a", (1, 0): "b"}
        return tuple(names.get(term, f"b{term[0]}") for term in self.terms)

    def _series(self, degree: int, domain: tuple[float, float]) -> Polynomial | Legendre:
        if self.basis == "raw":
            return Polynomial.basis(degree)
        return Legendre.basis(degree, domain=domain)

    def matrix(self, c_uf: np.ndarray, t_degc: np.ndarray | None) -> np.ndarray:
        """Design matrix (rows = samples) in this design's basis."""
        z = np.log(c_uf) if self.log else c_uf
        columns = []
        for i, m in self.terms:
            column = self._series(i, self.z_domain)(z)
            if m:
                column = column * self._series(m, self.t_domain)(t_degc)
            columns.append(column)
        return np.column_stack(columns)

    def to_raw(self) -> np.ndarray:
        """Matrix M such that raw power-basis coefficients = M @ coefficients in this basis."""

        def power_coef(series: Polynomial | Legendre, power: int) -> float:
            coef = series.convert(kind=Polynomial).coef
            return coef[power] if power < coef.size else 0.0

        terms = self.terms
        m_raw = np.empty((len(terms), len(terms)))
        for k, (i, m) in enumerate(terms):
            z_series = self._series(i, self.z_domain)
            t_series = self._series(m, self.t_domain) if m else Polynomial.basis(0)
            for r, (ri, rm) in enumerate(terms):
                m_raw[r, k] = power_coef(z_series, ri) * power_coef(t_series, rm)
        return m_raw


@dataclass(frozen=True, eq=False)
class GammaFit:
    """A fitted Γ / Γ_T / log model.

    Attributes
    ----------
    design
        Which model (order, log, temperature, interaction), the data ranges used to scale
        C and T, and the basis the least-squares problem was solved in.
    results
        statsmodels OLS results of the fit, in the basis it was solved in
        (``design.basis``); response in µm.  Basis-invariant quantities (fitted values,
        residuals, sums of squares, R², F) can be read from it directly.
    raw_transform
        Matrix M mapping ``results.params`` to the raw power-basis coefficients.
    condition_number
        2-norm condition number of the raw power-basis design matrix (C in µF, T in °C),
        the matrix Excel solved.
    condition_number_scaled
        Same for the centred/scaled Legendre design matrix.
    """

    design: _Design
    results: sm.regression.linear_model.RegressionResultsWrapper
    raw_transform: np.ndarray
    condition_number: float
    condition_number_scaled: float

    @property
    def coefficients(self) -> pd.Series:
        """Raw power-basis coefficients b0..bj[, g, g_CT] (or a, b), thesis units.

        b_i in µm/µF^i, g in µm/°C, g_CT in µm/(µF·°C); log model: a in µm, b in µm.
        """
        import pandas as pd

        return pd.Series(self.raw_transform @ self.results.params, index=self.design.names)

    @property
    def has_temperature(self) -> bool:
        return self.design.t_domain is not None

    @property
    def fitted_um(self) -> np.ndarray:
        """Fitted positions at the fitting data [µm]."""
        return np.asarray(self.results.fittedvalues)

    @property
    def residuals_um(self) -> np.ndarray:
        """Residuals x - Γ(C) at the fitting data [µm]."""
        return np.asarray(self.results.resid)

    @property
    def max_residual_um(self) -> float:
        """Maximum absolute residual [µm] (Table 5.1 row 1)."""
        return float(np.max(np.abs(self.residuals_um)))

    @property
    def r2(self) -> float:
        return float(self.results.rsquared)

    @property
    def r2_adj(self) -> float:
        return float(self.results.rsquared_adj)

    @property
    def std_error_um(self) -> float:
        """Standard error of the regression, sqrt(MS_residual) [µm] (Excel's "Standard Error")."""
        return float(np.sqrt(self.results.mse_resid))

    def predict(self, C: ArrayLike, temperature: ArrayLike | None = None) -> np.ndarray:
        """Position x [m] from capacitance C [F] (and temperature [°C] for Γ_T).

        SI in and out; converted to µF / µm only for evaluation.  Evaluated in the fit's
        own (by default well-conditioned) basis.  Meaningful only inside the fitted
        capacitance and temperature ranges.
        """
        c = np.asarray(C, dtype=float)
        if self.has_temperature != (temperature is not None):
            need = "requires a" if self.has_temperature else "takes no"
            raise ValueError(f"this Γ fit {need} temperature argument")
        t = (
            None
            if temperature is None
            else np.broadcast_to(np.asarray(temperature, float), c.shape)
        )
        c_flat, t_flat = _check_inputs(C=c.ravel(), temperature=None if t is None else t.ravel())
        x_um = self.design.matrix(c_flat * _UF_PER_F, t_flat) @ np.asarray(self.results.params)
        return (x_um / _UM_PER_M).reshape(c.shape)


def fit_gamma(
    C: ArrayLike,
    x: ArrayLike,
    order: int,
    temperature: ArrayLike | None = None,
    interaction: bool = False,
    basis: Basis = "scaled",
) -> GammaFit:
    """Fit Γ (Eq 5.4) or, with ``temperature``, Γ_T (Eq 7.13) by ordinary least squares.

    C in F, x in m, temperature in °C (SI in); the fit itself and everything it reports
    are in µF / µm.  ``interaction=True`` adds a C·T term (Table 7.2, last column).
    ``basis="scaled"`` (default) solves in the centred/scaled Legendre basis,
    ``basis="raw"`` in the raw power basis.
    """
    if isinstance(order, bool) or not isinstance(order, (int, np.integer)) or order < 1:
        raise ValueError(f"order must be an integer >= 1, got {order!r}")
    if interaction and temperature is None:
        raise ValueError("interaction=True needs a temperature")
    return _fit(
        C, x, temperature, order=int(order), log=False, interaction=interaction, basis=basis
    )


def fit_log_gamma(C: ArrayLike, x: ArrayLike, basis: Basis = "scaled") -> GammaFit:
    """Fit the log model x = a + b ln C (Table 5.1, column "ln"); C in F, x in m.

    ln is taken of C in µF, as in the thesis, so a is in µm and b in µm per ln(µF).
    """
    return _fit(C, x, None, order=1, log=True, interaction=False, basis=basis)


def _fit(
    C: ArrayLike,
    x: ArrayLike,
    temperature: ArrayLike | None,
    *,
    order: int,
    log: bool,
    interaction: bool,
    basis: Basis,
) -> GammaFit:
    """The one fitting path behind every variant."""
    if basis not in _BASES:
        raise ValueError(f"basis must be one of {_BASES}, got {basis!r}")
    c, t, x_m = _check_inputs(C=C, temperature=temperature, x=x)
    c_uf, x_um = c * _UF_PER_F, x_m * _UM_PER_M
    n_params = order + 1 + (t is not None) + interaction
    if c.size <= n_params:
        raise ValueError(f"{n_params} coefficients need more than {n_params} points, got {c.size}")
    if t is not None and np.ptp(t) == 0:
        raise ValueError("temperature is constant, so g is not identifiable")

    z = np.log(c_uf) if log else c_uf
    design = _Design(
        order=order,
        log=log,
        z_domain=(float(z.min()), float(z.max())),
        t_domain=None if t is None else (float(t.min()), float(t.max())),
        interaction=interaction,
        basis=basis,
    )
    raw, scaled = (replace(design, basis=b).matrix(c_uf, t) for b in ("raw", "scaled"))
    rank = np.linalg.matrix_rank(scaled)
    if rank < n_params:
        raise ValueError(
            f"design matrix has rank {rank} < {n_params} coefficients: needs more than "
            f"{order} distinct C values and a temperature not collinear with C"
        )
    # imported here: statsmodels takes ≈ 0.9 s to import, and the jobs that only evaluate Γ
    # (the observer over each capture, the real-time loop) never fit
    import statsmodels.api as sm

    results = sm.OLS(x_um, raw if basis == "raw" else scaled).fit()
    return GammaFit(
        design=design,
        results=results,
        raw_transform=design.to_raw(),
        condition_number=float(np.linalg.cond(raw)),
        condition_number_scaled=float(np.linalg.cond(scaled)),
    )


def _check_inputs(
    C: ArrayLike, temperature: ArrayLike | None, x: ArrayLike | None = None
) -> tuple[np.ndarray, ...]:
    """Validate and convert to 1-D float arrays, returned in the order C, temperature[, x]."""
    named = {"C": C, "temperature": temperature} | ({} if x is None else {"x": x})
    arrays = {k: np.asarray(v, dtype=float) for k, v in named.items() if v is not None}
    for name, a in arrays.items():
        if a.ndim != 1:
            raise ValueError(f"{name} must be one-dimensional, got shape {a.shape}")
        if not np.all(np.isfinite(a)):
            raise ValueError(f"{name} contains NaN or infinite values")
    lengths = {name: a.size for name, a in arrays.items()}
    if len(set(lengths.values())) > 1:
        raise ValueError(f"inputs must have the same length, got {lengths}")
    if np.any(arrays["C"] <= 0):
        raise ValueError("C must be positive (farads)")
    return tuple(arrays.get(name) for name in named)


def anova_table(fit: GammaFit) -> pd.DataFrame:
    """Excel-style ANOVA (Tables 5.2, 7.3): rows Regression, Residual, Total.

    Columns df, SS [µm²], MS [µm²], F, Significance F (the F test's p-value); cells Excel
    leaves blank are NaN.
    """
    import pandas as pd

    r = fit.results
    df_reg, df_res = int(r.df_model), int(r.df_resid)
    return pd.DataFrame(
        {
            "df": [df_reg, df_res, df_reg + df_res],
            "SS": [r.ess, r.ssr, r.centered_tss],
            "MS": [r.mse_model, r.mse_resid, np.nan],
            "F": [r.fvalue, np.nan, np.nan],
            "Significance F": [r.f_pvalue, np.nan, np.nan],
        },
        index=pd.Index(["Regression", "Residual", "Total"]),
    )


def coefficient_table(fit: GammaFit) -> pd.DataFrame:
    """Excel-style coefficient table for the raw power-basis coefficients (thesis units).

    Index b0..bj[, g, g_CT] (a, b for the log model); columns Coefficients,
    Standard Error, t Stat, P-value, Lower 95%, Upper 95% (t distribution, df_resid).
    """
    import pandas as pd

    test = fit.results.t_test(fit.raw_transform)
    lower, upper = test.conf_int(alpha=0.05).T
    return pd.DataFrame(
        {
            "Coefficients": np.ravel(test.effect),
            "Standard Error": np.ravel(test.sd),
            "t Stat": np.ravel(test.tvalue),
            "P-value": np.ravel(test.pvalue),
            "Lower 95%": lower,
            "Upper 95%": upper,
        },
        index=pd.Index(fit.design.names),
    )


def _stats_table(
    fits: dict[str, GammaFit], columns: dict[str, Callable[[GammaFit], float]]
) -> pd.DataFrame:
    import pandas as pd

    return pd.DataFrame(
        [
            {"model": label} | {col: get(fit) for col, get in columns.items()}
            for label, fit in fits.items()
        ]
    )


def model_selection_table(
    C: ArrayLike, x: ArrayLike, orders: tuple[int, ...] = (3, 4, 5, 6), include_log: bool = True
) -> pd.DataFrame:
    """Table 5.1: one row per model ("j=3", ..., "ln"); C in F, x in m.

    Columns model, max residual [µm], R², adjusted R².
    """
    fits = {f"j={j}": fit_gamma(C, x, j) for j in orders}
    if include_log:
        fits["ln"] = fit_log_gamma(C, x)
    return _stats_table(
        fits,
        {
            "max residual [µm]": lambda f: f.max_residual_um,
            "R²": lambda f: f.r2,
            "adjusted R²": lambda f: f.r2_adj,
        },
    )


def gamma_t_table(
    C: ArrayLike,
    x: ArrayLike,
    temperature: ArrayLike,
    orders: tuple[int, ...] = (4, 5, 6),
    interaction_order: int = 5,
) -> pd.DataFrame:
    """Table 7.2: Γ_T for each order plus order ``interaction_order`` with a C·T term.

    C in F, x in m, temperature in °C.  Columns model ("n=4", ..., "n=5 + C·T"), R²,
    adjusted R², standard error [µm], interaction p-value (NaN for models without one).
    """
    fits = {f"n={n}": fit_gamma(C, x, n, temperature) for n in orders}
    fits[f"n={interaction_order} + C·T"] = fit_gamma(
        C, x, interaction_order, temperature, interaction=True
    )
    return _stats_table(
        fits,
        {
            "R²": lambda f: f.r2,
            "adjusted R²": lambda f: f.r2_adj,
            "standard error [µm]": lambda f: f.std_error_um,
            "interaction p-value": lambda f: (
                coefficient_table(f).loc["g_CT", "P-value"] if f.design.interaction else np.nan
            ),
        },
    )


@dataclass(frozen=True)
class GammaPolynomial:
    """A chosen Γ as plain data (raw power-basis coefficients, thesis units) for later stages.

    Evaluating the raw basis is benign (the ill-conditioning of Table 5.2's basis hurts the
    solve, not the evaluation: at C ≈ 2–3 µF the cancellation costs ≈ 1e-10 µm).
    """

    coefficients: tuple[float, ...]  # b0..bj in µm/µF^i
    g: float = 0.0  # µm/°C (Γ_T, Eq 7.13)

    @classmethod
    def from_fit(cls, fit: GammaFit) -> GammaPolynomial:
        coefs = fit.coefficients
        powers = tuple(
            float(coefs[f"b{i}"]) for i in range(sum(1 for n in coefs.index if n.startswith("b")))
        )
        return cls(powers, float(coefs.get("g", 0.0)))

    @classmethod
    def from_record(cls, record: Mapping) -> GammaPolynomial:
        """The Γ a :meth:`record` holds (e.g. read back from ``gamma.json``)."""
        return cls(tuple(record["coefficients"]), record["g"])

    @property
    def order(self) -> int:
        """Order j of the polynomial in C (Eq 5.4)."""
        return len(self.coefficients) - 1

    def record(self) -> dict:
        """Plain data for a JSON artefact; :meth:`from_record` reads it back."""
        return asdict(self) | {"order": self.order}

    def predict(self, C: ArrayLike, temperature: ArrayLike | None = None) -> np.ndarray:
        """x [m] from C [F] (and T [°C], used only when g ≠ 0)."""
        x_um = Polynomial(self.coefficients)(np.asarray(C, dtype=float) * _UF_PER_F)
        if self.g:
            x_um = x_um + self.g * np.asarray(temperature, dtype=float)
        return x_um / _UM_PER_M


def load_gamma(path: str | Path) -> GammaPolynomial:
    """The Γ (Eq 5.4) or Γ_T (Eq 7.13) a fitting stage wrote as ``record() | provenance``."""
    return GammaPolynomial.from_record(json.loads(Path(path).read_text()))


def printed_range(
    printed: GammaPolynomial, x_max_um: float, temperature: float = 0.0
) -> tuple[float, float]:
    """The C interval [µF] on which a printed Γ (or Γ_T at ``temperature`` [°C]) runs
    monotonically from x = 0 to ``x_max_um``: the range of C its fit covered. A polynomial of
    order 5 has several such stretches; the widest is the physical one (C falls by ≈ 1 µF over
    the stroke, Table 4.2), the others are wiggles outside the data."""
    p = Polynomial(printed.coefficients) + printed.g * temperature
    crossings = {
        level: sorted(r.real for r in (p - level).roots() if abs(r.imag) < 1e-9 and r.real > 0)
        for level in (0.0, x_max_um)
    }
    turns = [r.real for r in p.deriv().roots() if abs(r.imag) < 1e-9]
    spans = [
        (min(a, b), max(a, b))
        for a in crossings[0.0]
        for b in crossings[x_max_um]
        if not any(min(a, b) < t < max(a, b) for t in turns)
    ]
    if not spans:
        raise ValueError(f"the printed Γ does not run monotonically from 0 to {x_max_um:g} µm")
    return max(spans, key=lambda s: s[1] - s[0])


def curve_difference(
    ours: GammaPolynomial,
    printed: GammaPolynomial,
    x_max_um: float,
    temperatures: Sequence[float] = (0.0,),
    points: int = 2001,
) -> dict[str, float]:
    """max |Γ_ours(C) − Γ_printed(C)| [µm] over the printed curve's C range (per temperature for
    Γ_T): how the fitted curves compare, which the ill-conditioned coefficients cannot say."""
    worst, lows, highs = 0.0, [], []
    for T in temperatures:
        lo, hi = printed_range(printed, x_max_um, T)
        C = np.linspace(lo, hi, points)
        T_arr = np.full_like(C, T)
        diff = (
            ours.predict(C / _UF_PER_F, T_arr) * _UM_PER_M
            - printed.predict(C / _UF_PER_F, T_arr) * _UM_PER_M
        )
        worst = max(worst, float(np.max(np.abs(diff))))
        lows.append(lo)
        highs.append(hi)
    return {"C low [µF]": min(lows), "C high [µF]": max(highs), "max |Γ − Γ_thesis| [µm]": worst}


def curve_table(
    fits: Mapping[str, GammaPolynomial],
    printed: GammaPolynomial,
    x_max_um: float,
    temperatures: Sequence[float] = (0.0,),
) -> pd.DataFrame:
    """One row per fit (e.g. "thesis order", "our order"): its order and
    :func:`curve_difference`."""
    import pandas as pd

    return pd.DataFrame(
        [
            {
                "fit": name,
                "order": fit.order,
                **curve_difference(fit, printed, x_max_um, temperatures),
            }
            for name, fit in fits.items()
        ]
    )
