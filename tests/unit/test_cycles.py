"""The cycle analysis (selfsense.methods.cycles) on recordings made here with known answers.

The main recording is a new user's kind (a piezo micromanipulator logged at 200 Hz): a raised-cosine
drive 0…100 V at 2 Hz through a Maxwell-slip hysteresis (three play operators on a linear gain,
written below), x settling from 4 µm below the loop with τ = 0.05 s, six full cycles, a ramp down
(0.8, 0.6, 0.4, 0.2 of full amplitude), a 1.2 s pause at 0 V, a ramp up (0.25, 0.5, 0.75), eight
full cycles and 0.4 of one, and noise. Its steady loop is known in closed form: stroke
c·A + Σ wᵢ(A − 2rᵢ) = 26 µm, largest branch gap Σ wᵢ·min(2rᵢ, A − 2rᵢ) = 2.4 µm (9.23 % of
stroke). The property tests use an ellipse x = B sin(ωt + φ − δ), whose loop width is 100·sin δ %
of its stroke 2B.
"""

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from selfsense.chapters import characterise as ch
from selfsense.methods.cycles import (
    REASONS,
    CycleRules,
    cycle_loops,
    find_cycles,
    protocol_period,
    running_mean,
    spectral_period,
    upward_crossings,
)
from selfsense.methods.metrics import branch_gap

FS, F, A = 200.0, 2.0, 100.0  # [Hz], [Hz], [V]
GAIN, RADII, WEIGHTS = 0.2e-6, (5.0, 15.0, 30.0), (0.03e-6, 0.03e-6, 0.03e-6)  # m/V, V, m/V
STROKE = GAIN * A + sum(w * (A - 2 * r) for r, w in zip(RADII, WEIGHTS))  # 26 µm
WIDTH = 100 * sum(w * min(2 * r, A - 2 * r) for r, w in zip(RADII, WEIGHTS)) / STROKE  # 9.23 %
#: the recording's drive: amplitude per cycle (of A), "pause" (1.2 s at 0 V), the last 0.4 of a
#: cycle
SCHEDULE = [1.0] * 6 + [0.8, 0.6, 0.4, 0.2, "pause", 0.25, 0.5, 0.75] + [1.0] * 8 + [("end", 0.4)]
SETTLE_UM, TAU = 4.0, 0.05


def play(u, r):
    """A play operator of radius r on a piecewise-monotone u, from its steady state at u = 0 (the
    output r below the input's top): the backlash follows u once u has moved 2r."""
    out, p = np.empty_like(u), r
    step = np.sign(np.diff(u, prepend=u[0]))
    edges = np.flatnonzero(np.diff(step) != 0) + 1
    for s, e in zip(np.r_[0, edges], np.r_[edges, len(u)]):
        seg = u[s:e]
        if step[s] > 0:
            q = np.maximum(p, seg - r)
        elif step[s] < 0:
            q = np.minimum(p, seg + r)
        else:
            q = np.clip(np.full_like(seg, p), seg - r, seg + r)
        out[s:e], p = q, q[-1]
    return out


def maxwell(u):
    """x [m] of the Maxwell-slip actuator: a linear gain and three play operators."""
    return GAIN * u + sum(w * play(u, r) for r, w in zip(RADII, WEIGHTS))


def drive(schedule=SCHEDULE, fs=FS, f=F):
    """The raised-cosine drive of a schedule, each cycle from 0 V (so amplitude steps join)."""
    parts, per = [], fs / f
    for item in schedule:
        if item == "pause":
            parts.append(np.zeros(int(round(1.2 * fs))))
            continue
        fraction, a = (item[1], 1.0) if isinstance(item, tuple) else (1.0, item)
        theta = 2 * np.pi * np.arange(int(round(fraction * per))) / per
        parts.append(A * a * (1 - np.cos(theta)) / 2)
    return np.concatenate(parts)


def recording(noise=0.001, seed=0, settle=True, fs=FS, f=F, schedule=SCHEDULE):
    """(u [V], x [m]) as logged: the Maxwell actuator, the settling transient, noise of ``noise``
    × the full amplitude (u) and × the stroke (x)."""
    u = drive(schedule, fs, f)
    t = np.arange(len(u)) / fs
    x = maxwell(u) - (SETTLE_UM * 1e-6 * np.exp(-t / TAU) if settle else 0.0)
    rng = np.random.default_rng(seed)
    n = len(u)
    return u + noise * A * rng.standard_normal(n), x + noise * STROKE * rng.standard_normal(n)


def measured(u, x, fs=FS, **kw):
    cycles = find_cycles(u, fs, x, **kw)
    return cycles, ch.characterise(
        ch.Reduced(fs, {"U": u, "x_laser": x}), "x_laser", 0.1, 1.0, cycles
    )


# -- the main recording ----------------------------------------------------------------------------


def test_the_closed_form_truth_is_the_steady_cycles_own():
    # the truth the tests hold the analysis to, checked on a dense noise-free steady cycle
    u = drive([1.0] * 3, fs=20000.0)
    x = maxwell(u)
    last = slice(2 * 10000, 3 * 10000)
    assert np.ptp(x[last]) == pytest.approx(STROKE, rel=1e-6)
    half = 5000
    grid = np.linspace(1, 99, 981)
    rise = np.interp(grid, u[last][:half], x[last][:half])
    fall = np.interp(grid, u[last][half:][::-1], x[last][half:][::-1])
    assert 100 * np.max(np.abs(fall - rise)) / STROKE == pytest.approx(WIDTH, abs=1e-3)


def test_stroke_and_loop_width_are_the_steady_cycles_and_the_dropped_are_told_apart():
    u, x = recording()
    cycles, m = measured(u, x)
    # the old measures over every sample: stroke +15 % (the settling's 4 µm), width blended
    old = ch.loop_measures(u, x, ch.rising(u))
    assert old["stroke"] / STROKE - 1 > 0.1
    assert abs(m["stroke"] / STROKE - 1) < 0.01
    assert abs(m["loop_width"] - WIDTH) < 0.5
    assert m["stroke_min"] <= m["stroke"] <= m["stroke_max"]
    assert m["loop_width_min"] <= m["loop_width"] <= m["loop_width_max"]
    # the pieces: 0.25 of a cycle before the first upward crossing and the first whole cycle
    # settling (warm-up); 5 + 8 full; 6 minor (0.8 … 0.2 down, the 0.2 one joined to the pause,
    # 0.25 … 0.75 up); the pause; the unfinished 0.15 of a cycle at the end
    assert cycles.counts() == {
        "used": 13,
        "warm-up": 2,
        "partial": 1,
        "pause": 1,
        "irregular": 0,
        "minor": 6,
    }
    assert cycles.source == "drive" and cycles.period_s == pytest.approx(1 / F, rel=1e-3)
    assert cycles.warmup_source == "detected"
    assert 0.6 < cycles.warmup_s < 0.65  # the end of the first whole cycle (0.125 + 0.5 s)
    assert cycles.amplitude == pytest.approx(A / 2, rel=0.01)
    np.testing.assert_allclose(
        cycles.minor_amplitudes, np.array([0.8, 0.6, 0.4, 0.25, 0.5, 0.75]) * A / 2, atol=2.5
    )
    assert m["cycles_used"] == 13 and m["dropped_minor"] == 6 and m["dropped_warm-up"] == 2
    assert m["period_from"] == "drive" and m["warmup_from"] == "detected"
    assert "13 cycles used, 10 dropped (2 warm-up, 1 partial, 1 pause, 6 minor)" in m["note"]
    assert "6 minor loops" in m["note"]
    # the gains of the steady cycles: through the loop's ends, stroke / A; by least squares
    # close to it (the loop is symmetric about its middle)
    assert m["gain_end"] == pytest.approx(STROKE / A, rel=0.01)
    assert m["gain_ls"] == pytest.approx(STROKE / A, rel=0.02)


def test_the_used_cycles_are_whole_periods_in_time_order_and_the_pieces_tile_the_record():
    u, x = recording()
    cycles = find_cycles(u, FS, x)
    pieces = sorted(
        [(s.start, s.stop) for s in cycles.used] + [(s.start, s.stop) for s, _ in cycles.dropped]
    )
    assert pieces[0][0] == 0 and pieces[-1][1] == len(u)
    assert all(a[1] == b[0] for a, b in zip(pieces, pieces[1:]))
    assert all(abs((s.stop - s.start) - FS / F) <= 1 for s in cycles.used)
    assert [s.start for s in cycles.used] == sorted(s.start for s in cycles.used)
    assert {why for _, why in cycles.dropped} <= set(REASONS)
    assert cycles.mask().sum() == sum(s.stop - s.start for s in cycles.used)


def test_a_given_warmup_is_honoured_and_not_detected_again():
    u, x = recording()
    cycles, m = measured(u, x, warmup_s=1.3)
    # every piece starting before 1.3 s: the leading quarter and three whole cycles
    assert cycles.warmup_source == "capture attribute warmup_s" and cycles.warmup_s == 1.3
    assert cycles.counts()["warm-up"] == 4 and cycles.counts()["used"] == 11
    assert all(s.start >= 1.3 * FS for s in cycles.used)
    assert m["warmup_s"] == 1.3 and m["warmup_from"] == "capture attribute warmup_s"
    # warmup_s = 0 says there is none: the settling cycle is used, and the stroke's median holds
    cycles, m = measured(u, x, warmup_s=0.0)
    assert cycles.counts()["warm-up"] == 0 and cycles.counts()["used"] == 14
    assert cycles.warmup_source == "capture attribute warmup_s" and cycles.warmup_s == 0.0
    assert abs(m["stroke"] / STROKE - 1) < 0.01


def test_a_recording_without_settling_drops_no_warmup():
    u, x = recording(settle=False)
    cycles = find_cycles(u, FS, x)
    assert cycles.warmup_source == "" and cycles.warmup_s == 0.0
    assert cycles.counts() == {
        "used": 14,
        "warm-up": 0,
        "partial": 2,
        "pause": 1,
        "irregular": 0,
        "minor": 6,
    }


def test_a_drift_through_the_record_is_not_taken_for_a_warmup_and_is_reported():
    u, x = recording(settle=False)
    x = x + 2e-6 * np.arange(len(x)) / len(x)  # 2 µm of creep over the record
    cycles = find_cycles(u, FS, x)
    assert cycles.warmup_source == "" and cycles.counts()["used"] == 14
    # the trend fitted through the used cycles: 2 µm over the record's n samples, read between
    # the first and the last used cycle's middles; the offsets' scatter (noise 0.1 % of stroke
    # over 100 samples a cycle, 14 cycles) leaves the fitted slope within 1 % of it
    expected = 2e-6 * cycles.drift_s * FS / len(x)
    assert cycles.drift == pytest.approx(expected, rel=0.01)
    assert f"x drifts {1e6 * cycles.drift:+.3g} µm" in cycles.summary(1e6, "µm")
    # and with the settling as well: the settling cycle dropped, no steady one lost to the drift
    u, x = recording()
    cycles = find_cycles(u, FS, x + 2e-6 * np.arange(len(x)) / len(x))
    assert cycles.counts()["warm-up"] == 2 and cycles.counts()["used"] == 13


def test_a_period_given_by_the_protocol_agrees_with_the_one_found():
    u, x = recording()
    found = find_cycles(u, FS, x)
    given = find_cycles(u, FS, x, period_s=1 / F)
    assert given.source == "protocol" and given.period_s == 1 / F
    assert found.source == "drive"
    assert found.period_s == pytest.approx(given.period_s, rel=1e-3)
    assert given.measured_period_s == pytest.approx(1 / F, rel=1e-3)
    assert given.counts() == found.counts()
    # a protocol period the drive does not have is said so, and no cycle is formed
    wrong = find_cycles(u, FS, x, period_s=0.37 / F)
    assert not wrong.periodic and "no periodic drive" in wrong.note and "protocol" in wrong.note


def test_protocol_period_reads_a_single_drive_frequency():
    assert protocol_period({"segments": [{"duration": 10, "frequency": 2.0, "hi": 100}]}) == 0.5
    assert (
        protocol_period({"segments": [{"duration": 1}, {"duration": 5, "frequency": 4.0}]}) == 0.25
    )
    assert (
        protocol_period(
            {"segments": [{"duration": 5, "frequency": 1}, {"duration": 5, "frequency": 2}]}
        )
        is None
    )
    assert protocol_period({"segments": [{"duration": 5, "hi": 100}]}) is None
    assert (
        protocol_period({"segments": [{"duration": 5, "frequency": 1, "terms": [[1, 3]]}]}) is None
    )


# -- no periodic drive ----------------------------------------------------------------------------


def steps(fs=1000.0):
    levels, durations = [0, 60, 20, 90, 40, 0], [1.0, 2.0, 1.5, 3.0, 2.5, 1.0]
    u = np.concatenate([np.full(int(d * fs), v, float) for v, d in zip(levels, durations)])
    rng = np.random.default_rng(3)
    return u + 0.05 * rng.standard_normal(len(u)), GAIN * u + 2e-9 * rng.standard_normal(len(u))


def test_steps_are_no_periodic_drive_and_are_measured_over_all_samples():
    u, x = steps()
    cycles, m = measured(u, x, fs=1000.0)
    assert not cycles.periodic and cycles.used == [] and cycles.dropped == []
    assert cycles.note.startswith("no periodic drive")
    assert "no periodic drive" in m["note"] and "over all samples" in m["note"]
    assert m["period_from"] == "no periodic drive" and "cycles_used" not in m
    assert m["stroke"] == pytest.approx(np.ptp(x), rel=1e-9)
    assert m["gain_ls"] == pytest.approx(GAIN, rel=0.01)
    # with a warm-up given, the samples before it are left out
    cycles, m = measured(u, x, fs=1000.0, warmup_s=1.5)
    assert "after the 1.5 s warm-up" in m["note"]
    assert m["stroke"] == pytest.approx(np.ptp(x[1500:]), rel=1e-9)


def test_an_arbitrary_waveform_is_no_periodic_drive():
    rng = np.random.default_rng(5)
    fs = 1000.0
    knots = rng.uniform(0, 100, 40)
    u = np.interp(np.arange(20000) / fs, np.sort(rng.uniform(0, 20, 40)), knots)
    cycles = find_cycles(u, fs, GAIN * u)
    assert not cycles.periodic and "no periodic drive" in cycles.note


# -- the pieces of the analysis --------------------------------------------------------------------


def test_the_spectral_period_and_the_crossings_of_a_noisy_sine():
    fs, period = 1000.0, 0.123
    t = np.arange(20000) / fs
    u = np.sin(2 * np.pi * t / period) + 0.01 * np.random.default_rng(0).standard_normal(len(t))
    assert spectral_period(u, fs) == pytest.approx(period, rel=2e-3)
    lag = period * fs
    u_ac = running_mean(u, 3) - running_mean(running_mean(u, 3), int(round(lag)))
    times = upward_crossings(u_ac, 0.2)
    assert len(times) == 162  # one per period, none from the noise
    assert np.median(np.diff(times)) == pytest.approx(lag, rel=1e-3)


def test_running_mean_keeps_its_window_whole_at_the_ends():
    a = np.arange(10.0)
    np.testing.assert_allclose(
        running_mean(a, 4), [1.5, 1.5, 1.5, 2.5, 3.5, 4.5, 5.5, 6.5, 7.5, 7.5]
    )


def test_a_cycles_loop_width_is_the_branch_gap_of_that_cycle_alone():
    fs, f, delta = 5000.0, 1.0, np.arcsin(0.12)
    t = np.arange(int(4 * fs)) / fs
    u, x = 100 * np.sin(2 * np.pi * f * t), 15e-6 * np.sin(2 * np.pi * f * t - delta)
    cycles = [slice(k * 5000, (k + 1) * 5000) for k in range(4)]
    strokes, gaps = cycle_loops(u, x, ch.rising(u), cycles, 40)
    for c, stroke, gap in zip(cycles, strokes, gaps):
        assert stroke == pytest.approx(np.ptp(x[c]))
        assert gap == pytest.approx(branch_gap(u[c], x[c], ch.rising(u[c])), rel=0.01)
        assert 100 * gap / stroke == pytest.approx(12.0, abs=0.05)


def test_rules_come_from_a_mapping_of_some_fields():
    assert CycleRules.from_mapping({"full_tolerance": 0.1}).full_tolerance == 0.1
    assert CycleRules.from_mapping(None) == CycleRules()


# -- properties ------------------------------------------------------------------------------------


@settings(max_examples=25, deadline=None)
@given(
    fs=st.floats(200.0, 50000.0),
    per_cycle=st.floats(48.0, 3000.0),
    cycles=st.integers(4, 30),
    phase=st.floats(0.5, 2 * np.pi - 0.5),
    tail=st.floats(0.1, 0.9),
    noise=st.floats(0.0, 0.002),
    width=st.floats(0.02, 0.3),
    seed=st.integers(0, 2**16),
)
def test_steady_ellipses_give_their_stroke_width_period_and_cycles(
    fs, per_cycle, cycles, phase, tail, noise, width, seed
):
    period = per_cycle / fs
    n = int((cycles + tail) * per_cycle)
    assume(n <= 1 << 19)
    end_phase = (phase + 2 * np.pi * n / per_cycle) % (2 * np.pi)
    assume(0.5 < end_phase < 2 * np.pi - 0.5)  # no crossing too near either end to be seen
    t = np.arange(n) / fs
    rng = np.random.default_rng(seed)
    amp, b, delta = 60.0, 15e-6, np.arcsin(width)
    u = 70 + amp * np.sin(2 * np.pi * t / period + phase) + noise * amp * rng.standard_normal(n)
    x = b + b * np.sin(2 * np.pi * t / period + phase - delta) + noise * b * rng.standard_normal(n)
    found, m = measured(u, x, fs=fs)
    # truth: the upward crossings at phase 2πk inside the record; a whole cycle between two
    crossings = np.arange(
        np.ceil(phase / (2 * np.pi)), (phase + 2 * np.pi * n / per_cycle) / (2 * np.pi)
    )
    assert found.periodic and found.source == "drive"
    assert found.period_s == pytest.approx(period, rel=5e-3)
    assert found.counts()["used"] == len(crossings) - 1
    assert found.counts()["partial"] == 2 and len(found.dropped) == 2
    assert abs(m["stroke"] / (2 * b) - 1) < 0.01
    assert abs(m["loop_width"] - 100 * width) < 0.5
    given_period = find_cycles(u, fs, x, period_s=period)
    assert given_period.counts() == found.counts()
    assert given_period.measured_period_s == pytest.approx(period, rel=5e-3)


@settings(max_examples=15, deadline=None)
@given(
    fs=st.floats(200.0, 20000.0),
    per_cycle=st.integers(60, 1000),  # whole samples: the schedule's cycles join at 0 V
    noise=st.floats(0.0, 0.002),
    seed=st.integers(0, 2**16),
)
def test_the_maxwell_recording_at_any_rate_and_period_gives_the_steady_loop(
    fs, per_cycle, noise, seed
):
    u, x = recording(noise=noise, seed=seed, fs=fs, f=fs / per_cycle)
    cycles, m = measured(u, x, fs=fs)
    counts = cycles.counts()
    # the leading quarter is warm-up or partial; the first block's full cycles are used or warm-up
    # as far as the settling (τ = 0.05 s) reaches into them; the second block's are all used
    assert counts["used"] + counts["warm-up"] + counts["partial"] == 16 and counts["used"] >= 8
    assert cycles.warmup_s < 0.5 + 6 * per_cycle / fs  # no further than the first block
    assert (counts["minor"], counts["pause"], counts["irregular"]) == (6, 1, 0)
    assert abs(m["stroke"] / STROKE - 1) < 0.01
    assert abs(m["loop_width"] - WIDTH) < 0.5
    assert cycles.period_s == pytest.approx(per_cycle / fs, rel=5e-3)


def test_a_hold_before_the_drive_is_a_pause_and_a_given_warmup_drops_it():
    u, x = recording(settle=False, schedule=["pause"] + [1.0] * 6)
    cycles = find_cycles(u, FS, x)
    # the hold and the first quarter cycle, then 5 whole ones, the last three quarters partial
    assert cycles.counts() == {
        "used": 5, "warm-up": 0, "partial": 1, "pause": 1, "irregular": 0, "minor": 0
    }  # fmt: skip
    assert cycles.dropped[0] == (slice(0, cycles.used[0].start), "pause")
    cycles = find_cycles(u, FS, x, warmup_s=1.2)
    assert cycles.counts()["warm-up"] == 1 and cycles.counts()["pause"] == 0
