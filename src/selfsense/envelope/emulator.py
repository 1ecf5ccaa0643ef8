"""Gaussian-process emulators of the twin's outputs, one per output, with leave-one-out
diagnostics.

An emulator stands in for the twin where the twin has not run: it gives, at any point of the
unknowns' unit cube, the expected output E[f(x)] and the emulator's own variance Var_em(x), the
two things the implausibility needs (Craig et al. 1997; Vernon, Goldstein & Bower 2010, Section
3). Per output (the output already on its declared scale, log or log(1 − R²); see
:func:`selfsense.envelope.validation.transform`):

- active inputs: the few unknowns that move the output (:func:`active_inputs`), the others left
  to the nugget;
- a linear mean on the active inputs (its coefficients by generalised least squares, their
  uncertainty in the emulator's variance), the output standardised by the residuals' sd;
- a Gaussian process on the residuals: an anisotropic Matérn (ν = 5/2) or squared-exponential
  kernel, one length scale per active input, times a constant, plus a WhiteKernel nugget that
  holds the seed's noise and the inactive inputs (Andrianakis et al. 2015, Section 2.3), its
  hyperparameters by maximum likelihood (scikit-learn's ``GaussianProcessRegressor``).

:func:`leave_one_out` gives the standardised leave-one-out errors in closed form (Rasmussen &
Williams 2006, Eq. 5.12) and says an output is not emulable when more than a declared fraction
exceed the threshold, the left-out runs' 95 % coverage falls short (Bastos & O'Hagan 2009), or
the left-out predictions explain too little of the output's variance (Q²).

Arrays in, arrays out: inputs in the unit cube (n × d), outputs as a vector (n). No file is read.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
from SALib.analyze import sobol as sobol_analysis
from SALib.sample import sobol as sobol_sample
from scipy.linalg import cho_solve, solve_triangular
from scipy.stats import chi2
from sklearn.exceptions import ConvergenceWarning
from sklearn.gaussian_process import GaussianProcessRegressor
from sklearn.gaussian_process.kernels import RBF, ConstantKernel, Matern, WhiteKernel

#: a 95 % interval of a normal: ±1.96 sd
Z95 = 1.959963984540054


@dataclass(frozen=True)
class Settings:
    """The declaration's emulator settings (workflow/validation.yaml, ``emulator``)."""

    kernel: str = "matern"
    nu: float = 2.5
    mean: str = "linear"
    nugget: float = 0.01
    nugget_bounds: tuple[float, float] = (1e-8, 1.0)
    length_scale_bounds: tuple[float, float] = (0.01, 100.0)
    restarts: int = 3
    max_active: int = 12
    min_index: float = 0.02
    loo_threshold: float = 3.0
    loo_max_fraction: float = 0.05
    loo_coverage95_min: float = 0.85
    loo_min_q2: float = 0.5
    seed: int = 0

    @classmethod
    def from_declaration(cls, emulator: dict, seed: int = 0) -> Settings:
        """From the declaration's ``emulator`` mapping."""
        loo = emulator["leave_one_out"]
        return cls(
            kernel=emulator["kernel"],
            nu=float(emulator["nu"]),
            mean=emulator["mean"],
            nugget=float(emulator["nugget"]["initial"]),
            nugget_bounds=tuple(emulator["nugget"]["bounds"]),
            length_scale_bounds=tuple(emulator["length_scale_bounds"]),
            restarts=int(emulator["restarts"]),
            max_active=int(emulator["active_inputs"]["max"]),
            min_index=float(emulator["active_inputs"]["min_total_index"]),
            loo_threshold=float(loo["threshold"]),
            loo_max_fraction=float(loo["max_fraction_beyond"]),
            loo_coverage95_min=float(loo["coverage95_min"]),
            loo_min_q2=float(loo["min_q2"]),
            seed=seed,
        )


@dataclass(frozen=True)
class Emulator:
    """One output's emulator: a linear mean on the active inputs, its coefficients by generalised
    least squares under the fitted process, plus the Gaussian process on the standardised
    residuals (Rasmussen & Williams 2006, Section 2.7, a vague prior on the coefficients)."""

    active: np.ndarray  # indices of the active inputs
    beta: np.ndarray  # the linear mean's intercept and slopes, on the standardised scale
    scale: float  # the sd the output was standardised by
    gp: GaussianProcessRegressor  # its kernel_ holds the fitted hyperparameters
    X_train: np.ndarray  # the runs, active inputs only
    residuals: np.ndarray  # standardised residuals about the linear mean
    cholesky: np.ndarray  # of K, the runs' covariance with the nugget
    weights: np.ndarray  # K⁻¹ r
    K_inv_H: np.ndarray  # K⁻¹ H
    A_inv: np.ndarray  # (Hᵀ K⁻¹ H)⁻¹, the coefficients' covariance

    @property
    def nugget(self) -> float:
        """The nugget's variance on the output's scale: the seed's noise and the inactive
        inputs, what no run can resolve."""
        return float(self.gp.kernel_.k2.noise_level) * self.scale**2

    def predict(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """E[f(x)] and Var_em(x), the emulator's variance of the function (the nugget excluded:
        the ensemble's variance enters the implausibility on its own), at the rows of ``X``.

        With h(x) = (1, x_active), k the kernel without its nugget, K the runs' covariance with
        it and H the runs' h (Rasmussen & Williams 2006, Eqs. 2.41–2.42):
        E = h(x)ᵀβ̂ + k(x)ᵀK⁻¹(y − Hβ̂) and
        Var_em = k(x, x) − k(x)ᵀK⁻¹k(x) + R(x)ᵀ(HᵀK⁻¹H)⁻¹R(x), R(x) = h(x) − HᵀK⁻¹k(x),
        the last term the linear mean's own uncertainty."""
        X = np.atleast_2d(np.asarray(X, dtype=float))
        Xa = X[:, self.active]
        h = _basis(Xa, len(self.beta))
        signal = self.gp.kernel_.k1
        K_trans = signal(Xa, self.X_train)  # m × n
        mean = h @ self.beta + K_trans @ self.weights
        v = solve_triangular(self.cholesky, K_trans.T, lower=True, check_finite=False)
        R = h.T - self.K_inv_H.T @ K_trans.T  # p × m
        var = (
            signal.diag(Xa)
            - np.einsum("ij,ij->j", v, v)
            + np.einsum("im,ij,jm->m", R, self.A_inv, R)
        )
        return self.scale * mean, np.maximum(var, 0.0) * self.scale**2


def _basis(Xa: np.ndarray, p: int) -> np.ndarray:
    """h(x): the intercept, and the active inputs for a linear mean (p = 1 + their number)."""
    return np.column_stack([np.ones(len(Xa)), Xa]) if p > 1 else np.ones((len(Xa), 1))


@dataclass(frozen=True)
class LeaveOneOut:
    """Leave-one-out diagnostics of one emulator: each run's standardised error
    (y_i − μ₋ᵢ)/σ₋ᵢ, the fraction beyond the threshold, the 95 % coverage, the left-out
    predictions' Q², and the verdict with its reason."""

    errors: np.ndarray
    fraction_beyond: float
    coverage95: float
    q2: float
    emulable: bool
    reason: str = ""


def active_inputs(X: np.ndarray, y: np.ndarray, max_active: int, min_index: float) -> np.ndarray:
    """The inputs that move ``y``: each input's share of the variance of a linear-plus-quadratic
    least-squares fit (its first-order Sobol' index under that fit for inputs uniform on [0, 1]:
    Var(a x + b x²) = a²/12 + ab/6 + 4b²/45), those with at least ``min_index``, at most
    ``max_active`` of them, the largest first; the single largest if none reaches it."""
    X, y = np.asarray(X, dtype=float), np.asarray(y, dtype=float)
    n, d = X.shape
    design = np.column_stack([np.ones(n), X, X**2])
    coef, *_ = np.linalg.lstsq(design, y, rcond=None)
    a, b = coef[1 : d + 1], coef[d + 1 :]
    share = (a**2 / 12 + a * b / 6 + 4 * b**2 / 45) / max(float(np.var(y)), 1e-300)
    order = np.argsort(share)[::-1]
    chosen = [i for i in order[:max_active] if share[i] >= min_index]
    return np.array(sorted(chosen or [int(order[0])]), dtype=int)


def fit(
    X: np.ndarray,
    y: np.ndarray,
    settings: Settings,
    noise_var: float | None = None,
    active: np.ndarray | None = None,
    noise_df: int | None = None,
) -> Emulator:
    """The emulator of one output from runs ``X`` (n × d, unit cube) and outputs ``y`` (n, on the
    output's declared scale).

    ``noise_var`` is the ensemble's variance (the seed's noise) the replicates measured, on the
    output's scale: the nugget is then held there (Andrianakis et al. 2015 estimate it from
    replicates), so that structure the kernel cannot follow (a jump, an output that is rough in
    the inputs) shows in the leave-one-out errors instead of hiding in a fitted nugget. With
    ``noise_df``, the replicates' degrees of freedom, it is fitted within that estimate's 99 %
    interval, s²·ν/χ²_ν(0.995) to s²·ν/χ²_ν(0.005), instead: a variance measured on a few
    replicates is itself uncertain (by ±50 % at 20 degrees of freedom). Without ``noise_var``
    the nugget is fitted within the declared bounds."""
    X, y = np.asarray(X, dtype=float), np.asarray(y, dtype=float)
    if active is None:
        active = active_inputs(X, y, settings.max_active, settings.min_index)
    Xa = X[:, active]
    H = _basis(Xa, 1 + len(active) if settings.mean == "linear" else 1)
    # first pass: ordinary least squares, whose residuals the hyperparameters are fitted to
    coef, *_ = np.linalg.lstsq(H, y, rcond=None)
    scale = float(np.std(y - H @ coef)) or 1.0
    ys = y / scale
    residual = ys - H @ (coef / scale)
    lengths = np.full(len(active), 0.5)
    if settings.kernel == "matern":
        shape = Matern(lengths, settings.length_scale_bounds, nu=settings.nu)
    else:
        shape = RBF(lengths, settings.length_scale_bounds)
    if noise_var is None:
        nugget = WhiteKernel(settings.nugget, settings.nugget_bounds)
    else:  # at the measured noise (never below the declared floor: a jitter)
        floor = settings.nugget_bounds[0]
        level = max(noise_var / scale**2, floor)
        if noise_df:
            low, high = (noise_df / chi2.ppf(q, noise_df) for q in (0.995, 0.005))
            nugget = WhiteKernel(level, (max(level * low, floor), max(level * high, 2 * floor)))
        else:
            nugget = WhiteKernel(level, "fixed")
    kernel = ConstantKernel(1.0, (1e-3, 1e3)) * shape + nugget
    gp = GaussianProcessRegressor(
        kernel,
        alpha=1e-10,
        n_restarts_optimizer=settings.restarts,
        random_state=settings.seed,
        normalize_y=False,
    )
    with warnings.catch_warnings():
        # a hyperparameter at its declared bound is a finding of the fit, not an error
        warnings.simplefilter("ignore", ConvergenceWarning)
        gp.fit(Xa, residual)
    # second pass: the coefficients by generalised least squares under the fitted covariance
    K = gp.kernel_(Xa) + 1e-10 * np.eye(len(ys))
    L = np.linalg.cholesky(K)
    K_inv_H = cho_solve((L, True), H, check_finite=False)
    A_inv = np.linalg.inv(H.T @ K_inv_H)
    beta = A_inv @ (K_inv_H.T @ ys)
    r = ys - H @ beta
    weights = cho_solve((L, True), r, check_finite=False)
    return Emulator(np.asarray(active), beta, scale, gp, Xa, r, L, weights, K_inv_H, A_inv)


def sobol_shares(emulator: Emulator, d: int, base: int, seed: int) -> tuple[np.ndarray, float]:
    """Each of the ``d`` unknowns' first-order Sobol' index on the emulator over the prior (the
    unit cube), as a share of the output's variance, and the share the nugget holds (the seed's
    noise and the inactive inputs, which no unknown explains): (shares (d,), noise share).

    The indices are those of the emulator's mean over its active inputs (Saltelli et al. 2010's
    estimator on ``base`` · (k + 2) points of a scrambled Sobol' sequence, SALib), times the mean's
    share Var(E[f]) / (Var(E[f]) + nugget) of the output's variance: what replaces Morris's
    grouped "driven by" with one number per unknown. An inactive unknown's index is 0 by the
    emulator's construction; an index below 0 (the estimator's noise) is read as 0."""
    k = len(emulator.active)
    problem = {"num_vars": k, "names": [str(i) for i in emulator.active], "bounds": [[0, 1]] * k}
    sample = sobol_sample.sample(problem, base, calc_second_order=False, seed=seed)
    X = np.full((len(sample), d), 0.5)
    X[:, emulator.active] = sample
    mean, _ = emulator.predict(X)
    var_mean = float(np.var(mean))
    shares = np.zeros(d)
    if var_mean <= 0.0 or k == 0:
        return shares, 1.0
    indices = sobol_analysis.analyze(
        problem, mean, calc_second_order=False, num_resamples=2, seed=seed
    )
    explained = var_mean / (var_mean + emulator.nugget)
    shares[emulator.active] = np.clip(np.asarray(indices["S1"], dtype=float), 0.0, None) * explained
    return shares, 1.0 - explained


def leave_one_out(emulator: Emulator, settings: Settings) -> LeaveOneOut:
    """Leave-one-out diagnostics of the fitted emulator on its own runs, hyperparameters and
    linear mean held (Rasmussen & Williams 2006, Eq. 5.12): with K the training covariance
    (nugget included) and r the standardised residuals, rᵢ − μ₋ᵢ = [K⁻¹r]ᵢ/[K⁻¹]ᵢᵢ and
    σ²₋ᵢ = 1/[K⁻¹]ᵢᵢ, so the standardised error is [K⁻¹r]ᵢ/√[K⁻¹]ᵢᵢ, and on the output's scale
    the left-out error is the residuals' sd times rᵢ − μ₋ᵢ. Judged by :func:`diagnose`."""
    e = emulator
    n = len(e.residuals)
    K_inv = cho_solve((e.cholesky, True), np.eye(n), check_finite=False)
    errors = e.weights / np.sqrt(np.diag(K_inv))
    left_out = e.scale * e.weights / np.diag(K_inv)
    y = e.scale * (e.residuals + _basis(e.X_train, len(e.beta)) @ e.beta)
    q2 = 1.0 - float(np.sum(left_out**2)) / max(float(np.sum((y - y.mean()) ** 2)), 1e-300)
    return diagnose(errors, q2, settings)


def diagnose(errors: np.ndarray, q2: float, settings: Settings) -> LeaveOneOut:
    """The verdict on standardised leave-one-out ``errors`` and the left-out Q²: under a good
    emulator the errors are near standard normal (Bastos & O'Hagan 2009), so an output is not
    emulable when more than ``loo_max_fraction`` of them exceed ``loo_threshold`` in size, when
    fewer than ``loo_coverage95_min`` lie within ±1.96, or when Q² = 1 − Σ(y − μ₋ᵢ)²/Σ(y − ȳ)²
    is below ``loo_min_q2`` (the emulator predicts little: a maximum-likelihood fit to an output
    it cannot follow shortens its length scales until it predicts its prior, whose errors look
    calibrated)."""
    errors = np.asarray(errors, dtype=float)
    beyond = float(np.mean(np.abs(errors) > settings.loo_threshold))
    coverage = float(np.mean(np.abs(errors) <= Z95))
    reasons = []
    if beyond > settings.loo_max_fraction:
        reasons.append(
            f"{beyond:.0%} of the leave-one-out errors beyond {settings.loo_threshold:g} "
            f"(at most {settings.loo_max_fraction:.0%})"
        )
    if coverage < settings.loo_coverage95_min:
        reasons.append(f"95 % coverage {coverage:.0%} (at least {settings.loo_coverage95_min:.0%})")
    if not q2 >= settings.loo_min_q2:
        reasons.append(f"Q² {q2:.2f} (at least {settings.loo_min_q2:g})")
    return LeaveOneOut(errors, beyond, coverage, q2, not reasons, "; ".join(reasons))
