"""The streaming ripple stage on whole captures: window alignment, chunk invariance, the twin."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from selfsense.methods.metrics import direction, hysteresis_percent
from selfsense.methods.ripple import SamplingPlan, WindowMeans, extract_impedance, impedance_series

from ..tolerances import sums

PLAN = SamplingPlan(1e5, 12, 4, 4)
FS = PLAN.fs


def test_window_means_match_the_impedance_windows():
    x = np.arange(480, dtype=float)
    index, (means,) = WindowMeans(PLAN, 1).process(x)
    blocks = extract_impedance(np.cos(np.arange(480)), np.sin(np.arange(480)), PLAN)
    np.testing.assert_array_equal(index, blocks.sample_index)
    np.testing.assert_allclose(means, index - (PLAN.block_len - 1) / 2)


def _chunks(data, sizes):
    start = 0
    for size in sizes:
        yield start, {k: v[start : start + size] for k, v in data.items()}
        start += size


@settings(max_examples=25, deadline=None)
@given(st.lists(st.integers(1, 700), min_size=1, max_size=12))
def test_impedance_series_is_chunk_invariant_and_integrates_charge(sizes):
    n = sum(sizes)
    rng = np.random.default_rng(n)
    k = np.arange(n)
    data = {
        "Ur": 0.1 * np.cos(2 * np.pi * 1e5 * k / FS),
        "Ir": 0.2 * np.cos(2 * np.pi * 1e5 * k / FS + 1.1),
        "U": rng.normal(size=n),
        "I": np.full(n, 2e-3),
    }
    whole = list(impedance_series(_chunks(data, [n]), PLAN, FS, ("U", "I")))
    parts = list(impedance_series(_chunks(data, sizes), PLAN, FS, ("U", "I")))
    for key in whole[0]:
        joined = np.concatenate([p[key] for p in parts])
        if key == "q":  # a running sum: chunk edges change only its last bits
            np.testing.assert_allclose(joined, whole[0][key], rtol=sums(n))
        else:
            np.testing.assert_array_equal(joined, whole[0][key])
    q = whole[0]["q"]
    if len(q):  # mean of ∫I dt over a window = I·(centre sample + 1)/fs for constant I
        np.testing.assert_allclose(q, 2e-3 * (whole[0]["time"] * FS + 1) / FS, rtol=sums(n))


def test_hysteresis_percent_of_a_known_loop():
    t = np.linspace(0, 2, 4001)
    u = 50 - 50 * np.cos(2 * np.pi * t)
    rising = direction(u)
    y = u + 5.0 * rising  # branches 10 apart on a range of 110
    vertical, horizontal = hysteresis_percent(u, y, rising)
    assert vertical == pytest.approx(100 * 10 / 110, rel=0.02)
    assert horizontal == pytest.approx(100 * 10 / 100, rel=0.05)
    assert hysteresis_percent(u, 2 * u, rising)[0] < 0.05  # bin averaging alone


def test_ce_tracks_the_twins_clamped_capacitance(stack_params, stack_daq):
    from selfsense.twin.bench import Bench, experiment_seed

    bench = Bench(stack_params, stack_daq, experiment_seed(3, "track"))
    t = np.arange(int(0.5 * FS)) / FS
    measured, truth = bench.step(t, 50 - 50 * np.cos(2 * np.pi * 10 * t))
    blocks = extract_impedance(measured["Ur"], measured["Ir"], PLAN)
    centre = blocks.sample_index - (PLAN.block_len - 1) / 2
    err = blocks.C_e / np.interp(centre, np.arange(len(t)), truth["C_e"]) - 1
    assert np.sqrt(np.mean(err**2)) < 0.01
