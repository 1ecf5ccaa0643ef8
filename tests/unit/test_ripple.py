"""Tests for selfsense.methods.ripple (thesis Chapter 3, Eq 3.3-3.13, Tables 3.1-3.2)."""

import math
import pickle

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from selfsense.methods.ripple import (
    RippleBlocks,
    RippleExtractor,
    SamplingPlan,
    extract_impedance,
    impedance_from_coefficients,
    plan_from_fs,
    table_3_1,
    table_3_2,
)

from ..tolerances import CLOSED_FORM, rtol

FR = 100e3
FS = 48e3
C_THESIS = 3.1e-6  # manufacturer capacitance
PHASE_LEAD = math.radians(65)  # ripple current leads voltage by ~65 deg (Section 3.4)


def series_rc(C, R):
    return R + 1 / (1j * 2 * math.pi * FR * C)


def r_for_lead(C, lead):
    """Series resistance giving a current lead of `lead` radians at FR."""
    return 1 / (2 * math.pi * FR * C * math.tan(lead))


def analytic_tol(fs, n):
    """The analytic ripple's phase 2π·fr·t is rounded to ε of itself, up to 2π·fr·n/fs rad; every
    estimate built from it inherits that relative error (R_e, the small in-phase part, 1/tan(65°)
    more), then sums of n terms."""
    return float(
        rtol((1 + 2 * math.pi * FR * n / fs) / math.tan(PHASE_LEAD), roundings=10 + n // 100)
    )


def ripple_pair(fs, n, C, R, amplitude=0.1, phase=0.3):
    """Ripple voltage and current sampled exactly at k/fs (no oversampling)."""
    t = np.arange(n) / fs
    V = amplitude * np.exp(1j * phase)
    I = V / series_rc(C, R)
    wt = 2 * math.pi * FR * t
    return abs(V) * np.cos(wt + np.angle(V)), abs(I) * np.cos(wt + np.angle(I))


# --- Eq 3.3-3.9 and Tables 3.1, 3.2 -----------------------------------------------------


def test_table_3_1_matches_thesis():
    expected = [
        (4, 0, 400, 100),
        (4, 2, 80, 20),
        (4, 12, 16, 4),
        (12, 0, 1200, 100),
        (12, 4, 48, 4),
    ]
    table = table_3_1()
    assert list(table.columns) == ["ns", "nf", "fs [kHz]", "fr_folded [kHz]"]
    assert len(table) == len(expected)
    for row, (ns, nf, fs_khz, folded_khz) in zip(table.itertuples(index=False), expected):
        assert (row[0], row[1]) == (ns, nf)
        assert row[2] == pytest.approx(fs_khz, rel=CLOSED_FORM)
        assert row[3] == pytest.approx(folded_khz, rel=CLOSED_FORM)


# Printed values of Table 3.2 as strings: the number of decimals is the thesis' rounding.
TABLE_3_2_PRINTED = [
    (1, "4", "1.27"),
    (2, "2", "0.637"),
    (4, "1", "0.318"),
    (8, "0.5", "0.159"),
    (12, "0.33", "0.106"),
    (16, "0.25", "0.08"),
]


def _decimals(printed):
    return len(printed.partition(".")[2])


def test_table_3_2_matches_thesis_rounding():
    table = table_3_2()
    assert list(table.columns) == ["np", "passband [kHz]", "bandwidth [kHz]"]
    assert len(table) == len(TABLE_3_2_PRINTED)
    for row, (n_periods, passband, bandwidth) in zip(
        table.itertuples(index=False), TABLE_3_2_PRINTED
    ):
        assert row[0] == n_periods
        assert round(row[1], _decimals(passband)) == float(passband)
        assert round(row[2], _decimals(bandwidth)) == float(bandwidth)


def test_thesis_plan_properties():
    plan = SamplingPlan(fr=FR, ns=12, nf=4, n_periods=4)
    assert plan.fs == pytest.approx(48e3, rel=CLOSED_FORM)
    assert plan.fr_folded == pytest.approx(4e3, rel=CLOSED_FORM)
    assert plan.block_len == 48
    assert plan.passband == pytest.approx(1e3, rel=CLOSED_FORM)
    assert plan.bandwidth == pytest.approx(1e3 / math.pi, rel=CLOSED_FORM)
    assert not plan.mirrored


@pytest.mark.parametrize("ns", [3, 4, 12])
@pytest.mark.parametrize("nf", range(8))
def test_every_fold_maps_ripple_onto_fs_over_ns(ns, nf):
    plan = SamplingPlan(FR, ns, nf, 1)
    # The alias of fr is fr - m*fs for the nearest integer m; its magnitude must be fs/ns
    # and its sign negative (mirrored) exactly for odd folds.
    alias = FR - round(FR / plan.fs) * plan.fs
    # fr − m·fs cancels fr/|alias| of its digits
    assert abs(alias) == pytest.approx(plan.fs / ns, rel=CLOSED_FORM * FR / abs(alias))
    assert (alias < 0) == plan.mirrored == (nf % 2 == 1)
    assert plan_from_fs(plan.fs, FR, ns, 1, min_folded=0) == plan


def test_plan_from_fs_accepts_thesis_rate():
    assert plan_from_fs(48000, FR, 12, 4) == SamplingPlan(FR, 12, 4, 4)


# --- invalid plans ----------------------------------------------------------------------


def _error(*args, **kwargs):
    with pytest.raises(ValueError) as info:
        plan_from_fs(*args, **kwargs)
    message = str(info.value)
    assert "\n" not in message
    return message


def test_non_folding_fs_names_nearest_valid_fs():
    assert _error(47000, FR, 12, 4) == (
        "fs = 47000 Hz does not fold fr = 100000 Hz onto fs/ns for ns = 12; "
        "nearest valid fs = 48000 Hz (nf = 4)"
    )


def test_fs_folding_into_mechanical_bandwidth_is_rejected():
    fs_nf8 = 2 * 12 * FR / (8 * 12 + 2)  # Eq 3.4, folded ripple 2040.8 Hz
    message = _error(fs_nf8, FR, 12, 4)
    assert message == (
        "folded ripple 2040.816 Hz lies inside the mechanical bandwidth 2500 Hz; "
        "nearest valid fs = 32432.43 Hz (nf = 6)"
    )
    assert plan_from_fs(32432.43, FR, 12, 4).nf == 6


def test_nearest_valid_fs_respects_mechanical_bandwidth():
    # 20 kHz is nearest to nf = 9 (20339 Hz), which folds to 1695 Hz; nf = 6 is the nearest usable.
    assert _error(20000, FR, 12, 4).endswith("nearest valid fs = 32432.43 Hz (nf = 6)")
    assert _error(1e6, FR, 12, 4).endswith("nearest valid fs = 1200000 Hz (nf = 0)")


def test_ripple_below_mechanical_bandwidth_has_no_valid_fs():
    message = _error(48000, 2000, 12, 4)
    assert message.startswith("fs = 48000 Hz does not fold fr = 2000 Hz")
    assert "no valid fs" in message


@pytest.mark.parametrize(
    "kwargs",
    [dict(ns=2), dict(nf=-1), dict(n_periods=0), dict(fr=-1.0), dict(ns=12.0)],
)
def test_sampling_plan_rejects_bad_parameters(kwargs):
    params = dict(fr=FR, ns=12, nf=4, n_periods=4) | kwargs
    with pytest.raises(ValueError):
        SamplingPlan(**params)


# --- Eq 3.6-3.13: analytic series R-C ---------------------------------------------------


@pytest.mark.parametrize("n_periods", [1, 2, 4, 8, 12])
def test_analytic_series_rc_is_recovered(n_periods):
    R = r_for_lead(C_THESIS, PHASE_LEAD)
    ur, ir = ripple_pair(FS, 4800, C_THESIS, R)
    blocks = extract_impedance(ur, ir, plan_from_fs(FS, FR, 12, n_periods))
    assert len(blocks) == 4800 // 12 - n_periods + 1
    np.testing.assert_allclose(blocks.C_e, C_THESIS, rtol=analytic_tol(FS, 4800))
    np.testing.assert_allclose(blocks.R_e, R, rtol=analytic_tol(FS, 4800))


# Low-frequency leakage after the two 2nd-order high-pass filters.  Even with a cut-off
# as low as 1.8 kHz (the thesis prints "18000 kHz"), a 100 V, 10 Hz drive leaks
# 100 V * (10/1800)^2 = 3 mV, and the ~10 mA drive current well below 1 uA.  The test
# uses 5 mV and 5 mA at 10 Hz plus DC offsets of 20 mV and 2 mA, i.e. the current leak is
# as large as half the unfiltered drive current.  DC cancels over whole periods (to rounding); the
# 10 Hz slope does not; it costs at most ~0.05 % in C_e and R_e here (bound 0.1 %).
LEAK_V, LEAK_I, DC_V, DC_I, F_LEAK = 5e-3, 5e-3, 20e-3, 2e-3, 10.0


@pytest.mark.parametrize("n_periods", [1, 2, 4, 8, 12])
@pytest.mark.parametrize("leak_phase", [0.0, 1.0, 2.5])
def test_analytic_series_rc_with_low_frequency_drive(n_periods, leak_phase):
    R = r_for_lead(C_THESIS, PHASE_LEAD)
    n = int(0.2 * FS)  # two leak periods: every slope of the 10 Hz drive is covered
    ur, ir = ripple_pair(FS, n, C_THESIS, R)
    t = np.arange(n) / FS
    ur = ur + DC_V + LEAK_V * np.sin(2 * math.pi * F_LEAK * t + leak_phase)
    ir = ir + DC_I + LEAK_I * np.sin(2 * math.pi * F_LEAK * t + leak_phase + 1.2)
    blocks = extract_impedance(ur, ir, plan_from_fs(FS, FR, 12, n_periods))
    np.testing.assert_allclose(blocks.C_e, C_THESIS, rtol=1e-3)
    np.testing.assert_allclose(blocks.R_e, R, rtol=1e-3)


@pytest.mark.parametrize(
    ("ns", "nf"), [(12, 0), (12, 1), (12, 3), (12, 4), (12, 5), (4, 2), (4, 3)]
)
def test_coefficients_follow_documented_phase_reference(ns, nf):
    plan = SamplingPlan(FR, ns, nf, 3)
    amplitude, phase = 0.1, 0.9
    ur = amplitude * np.cos(2 * math.pi * FR * np.arange(10 * ns) / plan.fs + phase)
    blocks = extract_impedance(ur, ur, plan)
    np.testing.assert_allclose(
        blocks.A_V, -ns / 4 * amplitude * math.sin(phase), rtol=analytic_tol(plan.fs, 10 * ns)
    )
    np.testing.assert_allclose(
        blocks.B_V, ns / 4 * amplitude * math.cos(phase), rtol=analytic_tol(plan.fs, 10 * ns)
    )


def test_coefficients_satisfy_eq_3_10_and_3_11():
    R = r_for_lead(C_THESIS, PHASE_LEAD)
    ur, ir = ripple_pair(FS, 480, C_THESIS, R, phase=2.0)
    b = extract_impedance(ur, ir, plan_from_fs(FS, FR, 12, 4))
    omega_C = 2 * math.pi * FR * C_THESIS
    np.testing.assert_allclose(b.A_V, b.A_I * R + b.B_I / omega_C, rtol=analytic_tol(FS, 480))
    np.testing.assert_allclose(b.B_V, b.B_I * R - b.A_I / omega_C, rtol=analytic_tol(FS, 480))


def test_impedance_from_coefficients_sign_convention():
    # Current (phasor B - jA) leading the voltage by 90 degrees is a pure capacitor.
    C_e, R_e = impedance_from_coefficients(A_V=0.0, B_V=1.0, A_I=-1.0, B_I=0.0, fr=FR)
    assert C_e == pytest.approx(1 / (2 * math.pi * FR))
    assert R_e == pytest.approx(0.0)


@pytest.mark.parametrize(("ns", "nf"), [(12, 1), (12, 3), (12, 5), (4, 3)])
def test_odd_fold_gives_positive_capacitance(ns, nf):
    fs = 2 * ns * FR / ((nf + 1) * ns - 2)  # Eq 3.5, written out independently of the module
    plan = plan_from_fs(fs, FR, ns, 4)
    assert plan.nf == nf and plan.mirrored
    R = r_for_lead(C_THESIS, PHASE_LEAD)
    ur, ir = ripple_pair(fs, 40 * ns, C_THESIS, R)
    blocks = extract_impedance(ur, ir, plan)
    np.testing.assert_allclose(blocks.C_e, C_THESIS, rtol=analytic_tol(fs, 40 * ns))
    np.testing.assert_allclose(blocks.R_e, R, rtol=analytic_tol(fs, 40 * ns))


VALID_PLANS = [(12, 4), (12, 3), (12, 5), (12, 0), (4, 12), (4, 3)]


@settings(deadline=None, max_examples=200)
@given(
    C=st.floats(0.5e-6, 10e-6),
    R=st.floats(0.01, 10.0),
    amplitude=st.floats(1e-3, 1.0),
    phase=st.floats(0.0, 2 * math.pi),
    plan_spec=st.sampled_from(VALID_PLANS),
    n_periods=st.integers(1, 16),
)
def test_property_series_rc_recovered(C, R, amplitude, phase, plan_spec, n_periods):
    ns, nf = plan_spec
    plan = SamplingPlan(FR, ns, nf, n_periods)
    ur, ir = ripple_pair(plan.fs, plan.block_len + 5 * ns, C, R, amplitude, phase)
    blocks = extract_impedance(ur, ir, plan)
    assert len(blocks) == 6
    np.testing.assert_allclose(blocks.C_e, C, rtol=1e-6)
    np.testing.assert_allclose(blocks.R_e, R, rtol=1e-6)


# --- streaming ------------------------------------------------------------------------


def test_windows_are_aligned_to_folded_periods():
    plan = plan_from_fs(FS, FR, 12, 4)
    blocks = extract_impedance(np.ones(1000), np.ones(1000), plan)
    assert blocks.sample_index.dtype == np.int64
    np.testing.assert_array_equal(blocks.sample_index, np.arange(47, 1000, 12))


def _fields(blocks):
    return [
        blocks.sample_index,
        blocks.C_e,
        blocks.R_e,
        blocks.A_V,
        blocks.B_V,
        blocks.A_I,
        blocks.B_I,
    ]


def _noisy_capture(plan, n, seed):
    rng = np.random.default_rng(seed)
    ur, ir = ripple_pair(plan.fs, n, C_THESIS, r_for_lead(C_THESIS, PHASE_LEAD))
    return ur + 1e-3 * rng.standard_normal(n), ir + 1e-3 * rng.standard_normal(n)


@settings(deadline=None, max_examples=150)
@given(
    chunk_sizes=st.lists(st.integers(0, 150), min_size=1, max_size=40),
    plan_spec=st.sampled_from([(12, 4, 1), (12, 4, 4), (12, 3, 12), (4, 2, 3)]),
    seed=st.integers(0, 2**32 - 1),
)
def test_chunking_is_byte_identical(chunk_sizes, plan_spec, seed):
    ns, nf, n_periods = plan_spec
    plan = SamplingPlan(FR, ns, nf, n_periods)
    ur, ir = _noisy_capture(plan, 1500, seed)
    whole = extract_impedance(ur, ir, plan)

    extractor = RippleExtractor(plan)
    edges = np.cumsum([0, *chunk_sizes])
    edges = np.append(edges[edges < ur.size], ur.size)
    parts = [extractor.process(ur[a:b], ir[a:b]) for a, b in zip(edges[:-1], edges[1:])]
    joined = RippleBlocks.concatenate(parts)
    for got, want in zip(_fields(joined), _fields(whole)):
        assert got.dtype == want.dtype
        assert got.tobytes() == want.tobytes()


def test_state_does_not_grow_with_stream_length():
    plan = plan_from_fs(FS, FR, 12, 8)
    ur, ir = _noisy_capture(plan, 10_007, seed=1)
    extractor = RippleExtractor(plan)
    extractor.process(ur, ir)
    size_short = len(pickle.dumps(extractor))
    for _ in range(50):
        extractor.process(ur, ir)
    # Leftover length and the period counter vary by a few bytes; retained samples
    # would add ~80 kB per chunk.
    assert len(pickle.dumps(extractor)) <= size_short + 256


def test_mismatched_chunks_are_rejected():
    extractor = RippleExtractor(plan_from_fs(FS, FR, 12, 4))
    with pytest.raises(ValueError, match="equally long"):
        extractor.process(np.zeros(10), np.zeros(11))
