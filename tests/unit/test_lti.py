"""selfsense.methods.lti against the scipy.signal functions it stands in for: the same operations
in the same order, so the twin's captures and the observer's estimates do not change; equal bit for
bit here, and within the rounding of their few operations on any other BLAS or CPU."""

import numpy as np
import pytest
import scipy.signal
from hypothesis import given, settings
from hypothesis import strategies as st

from selfsense.methods.lti import bilinear, filter_run, highpass2, tustin
from selfsense.methods.observer import HPOGains, _state_matrices

from ..tolerances import CLOSED_FORM, assert_close, sums


@pytest.mark.parametrize("gains", [HPOGains(17.0), HPOGains(16.4, 3.0, 0.7)])
@pytest.mark.parametrize("fs", [10e3, 48e3])
def test_tustin_is_cont2discrete_bilinear(gains, fs):
    A, B, C, D = _state_matrices(gains)
    for ours, theirs in zip(
        tustin(A, B, C, D, 1 / fs), scipy.signal.cont2discrete((A, B, C, D), 1 / fs, "bilinear")
    ):
        # a 2x2 solve: κ of I − A·dt/2 times a few roundings
        assert_close(
            ours, theirs, CLOSED_FORM * np.linalg.cond(np.eye(2) - A / (2 * fs)), atol=1e-300
        )


@pytest.mark.parametrize("cutoff", [33.3, 1e3, 18e3])
def test_butterworth_and_bilinear_are_scipys(cutoff):
    b, a = highpass2(cutoff)
    b_ref, a_ref = scipy.signal.butter(2, 2 * np.pi * cutoff, btype="high", analog=True)
    assert_close(b, b_ref, CLOSED_FORM, atol=1e-300)
    assert_close(a, a_ref, CLOSED_FORM)
    for ours, theirs in zip(bilinear(b, a, 48e3), scipy.signal.bilinear(b_ref, a_ref, 48e3)):
        assert_close(ours, theirs, CLOSED_FORM, atol=CLOSED_FORM)


@settings(max_examples=30, deadline=None)
@given(cutoff=st.floats(10.0, 20e3), q=st.floats(0.3, 2.0))
def test_a_second_order_high_pass_passes_q_at_its_cutoff(cutoff, q):
    """|H(jω_c)| = Q for s²/(s² + (ω_c/Q)s + ω_c²), and the high frequencies pass whole."""
    b, a = highpass2(cutoff, q)
    _, (at_cutoff, far) = scipy.signal.freqs(b, a, 2 * np.pi * np.array([cutoff, 1e4 * cutoff]))
    assert_close(abs(at_cutoff), q, CLOSED_FORM)
    assert_close(abs(far), 1.0, 1e-7)  # 1 − |H| ≈ (1/Q² − 2)/2·(ω_c/ω)² ≤ 1e-8 here


@settings(max_examples=30, deadline=None)
@given(split=st.integers(0, 2000), seed=st.integers(0, 2**32 - 1))
def test_filter_run_is_lfilter_and_carries_its_state(split, seed):
    b, a = bilinear(*highpass2(18e3), 48e3)
    x = np.random.default_rng(seed).normal(size=2000) + 50.0
    y_ref, z_ref = scipy.signal.lfilter(b, a, x, zi=np.zeros(2))
    y, z = np.empty_like(x), np.zeros(2)
    filter_run(b, a, x[:split], z, y[:split])
    filter_run(b, a, x[split:], z, y[split:])
    # a stable 2nd-order recursion: each output sums ≈ 1/(1 − |pole|) past terms' roundings
    poles = np.abs(np.roots(a))
    tol = sums(1 / (1 - poles.max()))
    assert_close(y, y_ref, tol, atol=tol * np.abs(x).max())
    assert_close(z, z_ref, tol, atol=tol * np.abs(x).max())


def test_two_processes_compiling_at_once_leave_a_cache_both_later_load(tmp_path):
    """numba writes its cache files under temporary names and renames them, so two jobs of a clean
    tree that compile the same kernel at once each leave a whole cache entry; a third process loads
    it instead of compiling (cache=True: compiled once per tree, not once per job)."""
    import os
    import subprocess
    import sys

    code = (
        "import numpy as np; from selfsense.methods.lti import filter_run; y = np.empty(4); "
        "filter_run(np.array([1.0, -1.0]), np.array([1.0, -0.5]), np.ones(4), np.zeros(1), y); "
        "print(list(y), len(filter_run.stats.cache_hits), len(filter_run.stats.cache_misses))"
    )
    env = os.environ | {"NUMBA_CACHE_DIR": str(tmp_path)}
    both = [
        subprocess.Popen([sys.executable, "-c", code], env=env, stdout=subprocess.PIPE, text=True)
        for _ in range(2)
    ]
    outputs = [p.communicate(timeout=300)[0] for p in both]
    assert all(p.returncode == 0 for p in both)
    third = subprocess.run(
        [sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True
    )
    values, hits, misses = third.stdout.rsplit(" ", 2)
    assert (int(hits), int(misses)) == (1, 0)
    y = np.empty(4)
    filter_run(np.array([1.0, -1.0]), np.array([1.0, -0.5]), np.ones(4), np.zeros(1), y)
    assert values == str(list(y)) and all(o.rsplit(" ", 2)[0] == values for o in outputs)
