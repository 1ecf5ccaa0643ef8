"""The Maxwell operator both twins share: the numba functions against their numpy references."""

import numpy as np
import pytest

from selfsense.methods.hysteresis import newton_step
from selfsense.twin import maxwell as M


@pytest.fixture
def elements():
    rng = np.random.default_rng(1)
    return rng.uniform(1e-6, 5e-6, 8), rng.uniform(0.5, 3.0, 8)


def test_operator_and_anchors_match_the_reference_along_a_path(elements):
    C_h, v_h = elements
    fast, ref = np.zeros(8), np.zeros(8)
    # reversals of growing and shrinking size, so elements saturate, release and re-saturate
    for q in 2e-5 * np.sin(np.linspace(0, 12 * np.pi, 600)) * np.linspace(0.2, 1.0, 600):
        u, slope = M.maxwell(q, fast, C_h, v_h)
        assert u == pytest.approx(M.maxwell_reference(q, ref, C_h, v_h), rel=1e-12, abs=1e-12)
        inside = np.abs((q - fast) / C_h) < v_h
        assert slope == pytest.approx(np.sum(1.0 / C_h[inside]), rel=1e-12)
        M.slide_anchors(q, fast, C_h, v_h)
        M.slide_anchors_reference(q, ref, C_h, v_h)
        np.testing.assert_allclose(fast, ref, rtol=1e-12, atol=1e-18)
        assert abs(M.maxwell(q, fast, C_h, v_h)[0]) <= M.span(v_h)


def test_sliding_and_summing_in_one_pass_is_the_two_passes_bit_for_bit(elements):
    """slide_and_sum (the kernels' once-a-sample step) against slide_anchors then maxwell: the same
    anchors and the same U_H, equal, not close (the twins' captures are made with it)."""
    C_h, v_h = elements
    one, two = np.zeros(8), np.zeros(8)
    rng = np.random.default_rng(2)
    path = 2e-5 * np.sin(np.linspace(0, 12 * np.pi, 600)) * np.linspace(0.2, 1.0, 600)
    for q in np.concatenate([path, rng.uniform(-3e-5, 3e-5, 400)]):
        u = M.slide_and_sum(q, one, C_h, v_h)
        M.slide_anchors(q, two, C_h, v_h)
        assert u == M.maxwell(q, two, C_h, v_h)[0]
        np.testing.assert_array_equal(one, two)


def test_newton_step_solves_a_balance_through_the_operator(elements):
    C_h, v_h = elements
    q_b, C, target = np.zeros(8), 3e-6, 40.0
    lo, hi, q = C * (target - M.span(v_h)), C * (target + M.span(v_h)), 0.0
    for _ in range(M.MAX_ITERATIONS):
        u, slope = M.maxwell(q, q_b, C_h, v_h)
        f = q / C + u - target
        if M.balanced(f, target):
            break
        q, lo, hi = newton_step(q, f, 1.0 / C + slope, lo, hi)
    assert q / C + M.maxwell_reference(q, q_b, C_h, v_h) == pytest.approx(target, rel=1e-12)


def test_kernel_constants_split_the_state(elements):
    C_h, v_h = elements
    kc = M.KernelConstants(3, np.zeros(2), C_h, v_h, np.full(2, 0.5), np.ones(2))
    state = np.arange(kc.n_state, dtype=float)
    q_b, U_c = kc.elements(state)
    assert kc.n_state == 13 and list(q_b) == list(range(3, 11)) and list(U_c) == [11.0, 12.0]
    q_b[0] = -1.0
    assert state[3] == -1.0
