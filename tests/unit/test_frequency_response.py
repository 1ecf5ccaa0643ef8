"""Fig 5.3's frequency response: the lock-in, the sweep plan, Eq 5.2's model and its peak, the
catalogue's sweep, and a short sweep on the twin against Eq 5.2 with the twin's true parameters."""

import dataclasses
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from selfsense.io.capture import open_capture
from selfsense.io.manifest import expand_protocols
from selfsense.methods import frequency_response as fr
from selfsense.methods.drive import Segment, drive_from_protocol
from selfsense.twin.bench import simulate_capture

from ..tolerances import CLOSED_FORM, root_condition, rtol

FS = 48000.0


def one_point(x, current, frequency, fs=FS):
    """measure() over a single window spanning the whole arrays."""
    point = fr.SweepPoint(frequency, 0, len(x))
    return fr.measure(np.zeros(10), [(point, {"x_laser": x, "I": current})], fs)


# --- the lock-in ----------------------------------------------------------------------------------


@settings(max_examples=60, deadline=None)
@given(
    n=st.integers(400, 20000),
    cycles=st.integers(2, 200),
    gain=st.floats(1e-2, 10.0),
    gain_deg=st.floats(-180.0, 180.0),
    q_amp=st.floats(1e-6, 1e-4),
    q_deg=st.floats(-180.0, 180.0),
    x_dc=st.floats(-1e-4, 1e-4),
    i_dc=st.floats(-0.01, 0.01),
    harmonic=st.floats(0.0, 1.0),
)
def test_lock_in_gives_back_a_known_transfer_function(
    n, cycles, gain, gain_deg, q_amp, q_deg, x_dc, i_dc, harmonic
):
    """x and I made from a known G = x/q over whole periods, with offsets (laser zero, probe offset)
    and a second harmonic on both: G comes back to rounding (offsets up to 10⁴ times the amplitude
    cost digits), at any frequency below fs/4."""
    cycles = min(cycles, n // 4)
    f = cycles * FS / n
    G = gain * np.exp(1j * np.radians(gain_deg))
    Q = q_amp * np.exp(1j * np.radians(q_deg))
    k = np.arange(-1, n)
    w = 2 * np.pi * f / FS
    q = np.real(Q * np.exp(1j * w * k)) + harmonic * q_amp * np.cos(2 * w * k)
    current = np.diff(q) * FS + i_dc  # the sampled current whose running sum is q
    x = (
        np.real(G * Q * np.exp(1j * w * k[1:]))
        + harmonic * abs(G) * q_amp * np.sin(2 * w * k[1:])
        + x_dc
    )
    measured = one_point(x, current, f)
    assert abs(measured.G[0] / G - 1) < 1e-7


def test_lock_in_rejects_the_folded_ripple_and_drift_a_plain_dft_leaks():
    """The folded ripple (0.18 A near fs/ns = 4 kHz) beside a 40 mA drive current at 3.65 kHz, and
    0.3 µm of laser drift over 19 periods of a 1.4 µm amplitude at 10 Hz (the sweep's levels): the
    Hann window keeps both below 0.05 %, where a rectangular window leaks 1/(π·periods)."""
    for f, cycles, G, I, ripple, drift in (
        (3650.0, 1387, 0.8, 0.04, 0.18, 0.0),
        (10.0, 19, 0.058, 1.5e-3, 0.0, 0.3e-6),
    ):
        t = np.arange(round(cycles * FS / f)) / FS
        G, I = G * np.exp(-0.7j), I * np.exp(0.3j)
        current = np.real(I * np.exp(2j * np.pi * f * t)) + ripple * np.cos(
            2 * np.pi * 4012.0 * t + 0.4
        )
        x = np.real(G * fr.charge_phasor(I, f, FS) * np.exp(2j * np.pi * f * t)) + drift * t / t[-1]
        assert abs(one_point(x, current, f).G[0] / G - 1) < 5e-4, f
        rectangular = [2 * np.mean(y * np.exp(-2j * np.pi * f * t)) for y in (x, current)]
        assert abs(rectangular[0] / fr.charge_phasor(rectangular[1], f, FS) / G - 1) > 2e-3, f


def test_charge_phasor_tends_to_eq_5_2s_integrator_at_low_frequency():
    assert fr.charge_phasor(1.0, 1.0, FS) == pytest.approx(1 / (2j * np.pi), rel=1e-4)
    # at 3.6 kHz the running sum differs from I/(jω) by half a sample of phase: 13.5°
    lag = np.degrees(np.angle(fr.charge_phasor(1.0, 3600.0, FS) * 2j * np.pi * 3600.0))
    assert lag == pytest.approx(3600.0 / FS * 180.0, rel=CLOSED_FORM)


# --- the sweep plan -------------------------------------------------------------------------------


def test_sweep_plan_discards_settling_periods_and_skips_transitions():
    segments = [
        Segment(0.5),
        Segment(0.25, 2.0, 0.0, 10.0),
        Segment(2.0, 10.0, 10.0, 30.0),
        Segment(0.05, 10.0, 10.0, 15.0),
        Segment(0.4, 1000.0, 15.0, 25.0),
    ]
    plan = fr.sweep_plan(segments, FS, settle_s=0.02)
    assert plan.rest == (0, 24000)
    ten, thousand = plan.points
    assert (ten.frequency, ten.start, ten.stop - ten.start) == (10.0, round(0.85 * FS), 19 * 4800)
    assert (thousand.frequency, thousand.start, thousand.stop - thousand.start) == (
        1000.0,
        round(2.82 * FS),
        380 * 48,
    )


def test_sweep_plan_needs_a_rest_at_0_V_first():
    with pytest.raises(ValueError, match="hold at 0 V"):
        fr.sweep_plan([Segment(2.0, 10.0, 10.0, 30.0)], FS, 0.02)
    with pytest.raises(ValueError, match="hold at 0 V"):
        fr.sweep_plan([Segment(0.5, 0.0, 0.0, 20.0), Segment(2.0, 10.0, 10.0, 30.0)], FS, 0.02)


@pytest.mark.parametrize("campaign", ["thesis", "smoke"])
def test_catalogue_sweep_is_continuous_whole_periods_and_clear_of_the_folded_ripple(
    campaign, stack_daq
):
    drive = drive_from_protocol(expand_protocols(["ch5"], campaign)["ch5_sweep"].protocol)
    for seg, after in zip(drive.segments, drive.segments[1:]):
        periods = seg.duration * seg.frequency  # whole, or a half for the rises between levels
        assert periods == pytest.approx(round(periods), abs=1e-6) or periods == pytest.approx(0.5)
        end = seg.value(np.array([seg.duration]))[0]
        # a sine's phase 2π·f·t is rounded to ε of itself: ε·2π·(periods) of the amplitude (≤ 100 V)
        assert end == pytest.approx(
            after.value(np.zeros(1))[0], abs=float(rtol(1 + 2 * np.pi * periods)) * 100.0
        )
    plan = fr.sweep_plan(drive.segments, stack_daq.fs, 0.02)
    folded = stack_daq.fs / stack_daq.ns
    assert all(abs(p.frequency - folded) >= 150 for p in plan.points)
    assert len(plan.points) >= 6


# --- Eq 5.2 and its resonance ---------------------------------------------------------------------

MODEL = {"C_P0": 3.13e-6, "dC_x": -0.03, "alpha": 9.36, "k": 25.1e6, "m": 0.1017, "b": 160.0}


def test_model_is_eq_5_2_with_c_p_at_the_operating_position():
    """At DC, Eq 5.2 reduces to Eq 5.3's 1/a0 = 1/(α + C_P k/α); C_P follows Eq 4.4."""
    for x in (0.0, 10e-6):
        c_p = MODEL["C_P0"] + MODEL["dC_x"] * x
        G = fr.transfer_function(MODEL, x)
        a0 = MODEL["alpha"] + c_p * MODEL["k"] / MODEL["alpha"]
        assert fr.evaluate(G, np.array([1e-3]))[0].real == pytest.approx(1 / a0)
    # the poles: the stack stiffened by α²/C_P with the charge held
    wn = np.sqrt((MODEL["k"] + MODEL["alpha"] ** 2 / MODEL["C_P0"]) / MODEL["m"])
    G = fr.transfer_function(MODEL)
    den = np.squeeze(G.den[0][0])
    poles = G.poles()
    assert np.abs(poles) == pytest.approx(
        [wn, wn], rel=float(rtol(np.max(root_condition(den, poles))))
    )


def test_model_peak_and_the_sampled_peak_find_the_resonance():
    G = fr.transfer_function(MODEL)
    wn = np.sqrt((MODEL["k"] + MODEL["alpha"] ** 2 / MODEL["C_P0"]) / MODEL["m"])
    zeta = MODEL["b"] / (2 * MODEL["m"] * wn)
    f_peak = wn * np.sqrt(1 - 2 * zeta**2) / (2 * np.pi)
    f, g = fr.model_peak(G, 10.0, 8000.0)
    assert f == pytest.approx(f_peak, rel=1e-5)
    # at a maximum |G| is flat: an error δ in f costs ≈ ½δ²·(f²|G''|/|G|) ≈ 2δ²Q², Q = 1/(2ζ), with
    # δ ≤ 1e-5 (asserted just above)
    assert g == pytest.approx(
        abs(fr.evaluate(G, np.array([f_peak]))[0]), rel=2 * (1e-5 / (2 * zeta)) ** 2 + CLOSED_FORM
    )
    # sampled every 50 Hz (as the catalogue's sweep is near its peak): within 0.5 % of the peak
    grid = np.arange(3000.0, 4400.0, 50.0) + 17.0
    f_sampled, _ = fr.measured_peak(grid, np.abs(fr.evaluate(G, grid)))
    assert f_sampled == pytest.approx(f_peak, rel=5e-3)
    assert math.isnan(
        fr.measured_peak(grid[:10], np.abs(fr.evaluate(G, grid[:10])))[0]
    )  # not bracketed


# --- the twin -------------------------------------------------------------------------------------


def test_twin_sweep_matches_eq_5_2_with_the_twins_true_parameters(
    tmp_path, stack_params, stack_daq
):
    """The smoke campaign's sweep on the twin, analysed as the rule does, against Eq 5.2 with the
    twin's true k, α, C_P0, ΔCx, m, b.

    The laser's 0.3 µm rounding is off here: undithered, it biases the fundamental of a 1.4 µm
    sine by up to ≈ 1.5 % (what the campaign's Fig 5.3 shows, docs/deviations.md), which is the
    instrument, not the mechanics this test holds to Eq 5.2. Below the resonance (100 Hz, 1 kHz)
    then within 1 % and 0.5°: the laser's slow drift moves < 1 nm over a measurement window,
    C_P at the operating position is known to ≈ 0.05 %, and the twin's Tustin frequency warping
    is < 0.05 % there. Through the resonance (3.3–3.8 kHz) the twin follows Eq 5.2 at the warped
    frequency (2/h)·tan(ωh/2) of its Tustin-integrated mechanics (1.8 % above ω at 3.6 kHz, which
    moves a Q ≈ 15 peak by more than its half-width); within 2 % and 2° there.
    """
    stack_params = dataclasses.replace(
        stack_params,
        instruments=dataclasses.replace(stack_params.instruments, laser_resolution=0.0),
    )
    s = stack_params.stack
    truth = {"C_P0": s.C_P0, "dC_x": s.dC_x, "alpha": s.alpha, "k": s.k, "m": s.m, "b": s.b}
    drive = drive_from_protocol(expand_protocols(["ch5"], "smoke")["ch5_sweep"].protocol)
    path = simulate_capture(
        tmp_path / "sweep.nc", stack_params, stack_daq, drive, {}, 5, "ch5_sweep"
    ).path
    plan = fr.sweep_plan(drive.segments, stack_daq.fs, 0.02)
    with open_capture(path) as cap:
        rest = cap.read(["x_laser"], *plan.rest)["x_laser"]
        measured = fr.measure(
            rest, ((p, cap.read(["x_laser", "I"], p.start, p.stop)) for p in plan.points), cap.fs
        )
        cap.read(["U", "Ur", "Ir", "F"])  # the amplitudes are chosen so that no channel clips
        assert set(cap.stats.clipped) == {"U", "I", "Ur", "Ir", "x_laser", "F"}
        assert not any(cap.stats.clipped.values()), cap.stats.clipped
    G = fr.transfer_function(truth, measured.operating_position)
    below = measured.frequency < 2000
    assert below.sum() == 2 and (~below).sum() == 4
    ratio = measured.G[below] / fr.evaluate(G, measured.frequency[below])
    assert np.abs(np.abs(ratio) - 1).max() < 0.01
    assert np.abs(np.degrees(np.angle(ratio))).max() < 0.5
    h = 1 / stack_daq.fs
    warped = 2 / h * np.tan(np.pi * measured.frequency[~below] * h) / (2 * np.pi)
    ratio = measured.G[~below] / fr.evaluate(G, warped)
    assert np.abs(np.abs(ratio) - 1).max() < 0.02
    assert np.abs(np.degrees(np.angle(ratio))).max() < 2.0
