"""Tolerances derived from each comparison's conditioning, so that the suite passes on any x86-64
CPU and BLAS kernel, not only on the machine where it first passed.

Two float64 computations of one quantity differ by about N·κ·ε: ε = 2.2e-16 the unit roundoff,
N the roundings along the way and κ the condition number, how much the computation amplifies a
relative perturbation of its inputs. Another BLAS kernel, FMA contraction or SIMD width changes
which roundings happen, not κ. Every bound below is MARGIN·N·κ·ε with a margin of 100 over the
estimate; where κ depends on the input (a frequency response near a cancellation, a polynomial
basis) the test computes it.
"""

import numpy as np

EPS = np.finfo(float).eps
MARGIN = 100.0


def rtol(kappa=1.0, roundings=10):
    """Relative tolerance for a result computed two ways with condition number kappa."""
    return MARGIN * roundings * np.asarray(kappa) * EPS


#: closed forms of a few dozen operations without cancellation (κ ≈ 1): ≈ 1e-12
CLOSED_FORM = rtol(1.0, roundings=45)


def sums(n):
    """Relative tolerance for sums or means of n comparable terms taken in another order or chunking
    (worst-case error n·ε relative to the sum of magnitudes; the tests' terms have one sign or a
    mean well away from zero, so κ ≈ 1)."""
    return rtol(1.0, roundings=max(int(n), 10))


def polynomial_condition(coefficients, s):
    """κ of evaluating Σ a_k s^k at s: Σ|a_k||s|^k / |Σ a_k s^k| (highest power first, as numpy)."""
    c = np.atleast_1d(np.squeeze(coefficients))
    s = np.asarray(s)
    return np.polyval(np.abs(c), np.abs(s)) / np.abs(np.polyval(c, s))


def rational_condition(tf, s):
    """κ of a SISO transfer function evaluated at s: the numerator's plus the denominator's."""
    return polynomial_condition(tf.num[0][0], s) + polynomial_condition(tf.den[0][0], s)


def resolvent_condition(A, s):
    """κ of a state-space response C(sI − A)⁻¹B at each s: the 2-norm condition of sI − A."""
    eye = np.eye(A.shape[0])
    return np.array([np.linalg.cond(si * eye - A) for si in np.atleast_1d(s)])


def assert_close(actual, desired, rtol, atol=0.0):
    """np.testing.assert_allclose with a tolerance per element (its message formats scalars
    only)."""
    actual, desired = np.asarray(actual), np.asarray(desired)
    bound = atol + rtol * np.abs(desired)
    excess = np.abs(actual - desired) / np.where(bound > 0, bound, np.inf)
    bad = ~(np.abs(actual - desired) <= bound)
    if bad.any():
        k = np.unravel_index(np.argmax(np.where(bad, excess, -1)), bad.shape) if bad.ndim else ()
        tolerance = np.broadcast_to(bound, bad.shape)[k]
        raise AssertionError(
            f"{bad.sum()} of {bad.size} elements differ beyond their tolerance; worst at "
            f"{k}: {actual[k]!r} vs {desired[k]!r} (tolerance {tolerance:.3g})"
        )


def root_condition(coefficients, root):
    """κ of a simple root r of Σ a_k s^k: Σ|a_k||r|^k / (|r|·|p'(r)|) (Wilkinson)."""
    c = np.atleast_1d(np.squeeze(coefficients))
    return np.polyval(np.abs(c), np.abs(root)) / (
        np.abs(root) * np.abs(np.polyval(np.polyder(c), root))
    )
