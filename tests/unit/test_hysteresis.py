"""An actuator's own Maxwell model: the numba kernels against their references, recovery of a
model from its own loops, and on the twin's stack the held-out feedforward error against the one
the twin's own rate-independent model gives."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from selfsense.chapters.characterise import reduce_capture, steady_cycles
from selfsense.methods.drive import Drive, Segment
from selfsense.methods.hysteresis import (
    MaxwellSlip,
    element_strains,
    element_strains_reference,
    fit_maxwell_slip,
    positions_reference,
    thresholds,
)
from selfsense.twin import kernel as K
from selfsense.twin.bench import simulate_capture
from selfsense.verify.hysteresis_truth import twin_voltage

FS = 48000.0


def sweep(amplitudes, points=400):
    """A position record of whole cycles 0 → a → 0 per amplitude (cosine shaped) [m]."""
    phase = np.linspace(0, 2 * np.pi, points, endpoint=False)
    return np.concatenate([a * 0.5 * (1 - np.cos(phase)) for a in amplitudes])


def model(order, seed, stroke=30e-6):
    rng = np.random.default_rng(seed)
    return MaxwellSlip(
        u0=float(rng.uniform(-5, 5)),
        c0=float(rng.uniform(2e6, 4e6)),
        r=thresholds(order, stroke / 2),
        k=rng.uniform(0.0, 1e6, order),
    )


@settings(max_examples=25, deadline=None)
@given(
    st.lists(st.floats(-1e-5, 1e-5), min_size=2, max_size=60),
    st.lists(st.floats(1e-9, 1e-5), min_size=1, max_size=6),
)
def test_the_element_kernel_equals_its_reference(x, r):
    x, r = np.array(x), np.array(r)
    np.testing.assert_array_equal(element_strains(x, r), element_strains_reference(x, r))
    rows = np.arange(1, len(x), 3)  # at some samples only, the anchors moved by all of them
    np.testing.assert_array_equal(
        element_strains(x, r, rows), element_strains_reference(x, r, rows)
    )


@settings(max_examples=20, deadline=None)
@given(st.integers(1, 8), st.integers(0, 1000), st.lists(st.floats(1e-6, 30e-6), max_size=4))
def test_the_forward_kernel_equals_its_reference(order, seed, amplitudes):
    m = model(order, seed)
    u = m.voltage(sweep([30e-6, *amplitudes], points=50))
    # a balance solved to 1e-12 of the voltage: positions agree to that over the loop's slope
    tolerance = 1e-12 * (1 + np.abs(u).max()) / m.c0
    np.testing.assert_allclose(m.position(u), positions_reference(m, u), rtol=0, atol=tolerance)


@pytest.mark.parametrize("order", [1, 3, 6])
def test_forward_inverts_the_voltage(order):
    """x → U → x is the identity, also across minor loops (the anchors keep the history)."""
    m = model(order, seed=order)
    x = sweep([30e-6, 12e-6, 30e-6, 5e-6, 30e-6])
    np.testing.assert_allclose(m.position(m.voltage(x)), x, rtol=0, atol=1e-15)


@pytest.mark.parametrize("order", [2, 5])
def test_a_model_is_recovered_from_its_own_loops(order):
    """Data made by a model on the fit's own threshold grid: the fit finds its loops exactly
    (errors at the solver's resolution) with no more elements than it has."""
    truth = model(order, seed=10 + order)
    x = sweep([30e-6] * 9)
    u = truth.voltage(x)
    cycles = [slice(i * 400, (i + 1) * 400) for i in range(1, 9)]
    fit = fit_maxwell_slip(u, x, cycles)
    assert fit.cycles == (3, 3, 2)
    assert fit.model.order <= order
    assert max(fit.feedforward) < 1e-6
    assert max(fit.forward) < 1e-6


def test_a_long_record_of_short_cycles_is_fitted_on_a_spread_of_whole_cycles():
    """Thousands of cycles of a few dozen samples (a fast drive in a long capture's block means):
    the fit takes MAX_CYCLES of them, whole, and finds the loop as on a short record."""
    truth = model(4, seed=3)
    x = sweep([30e-6] * 3001, points=30)
    cycles = [slice(i * 30, (i + 1) * 30) for i in range(1, 3001)]
    fit = fit_maxwell_slip(truth.voltage(x), x, cycles)
    assert fit.cycles == (30, 30, 30)
    assert fit.model.order <= 4 and max(fit.feedforward) < 1e-6


def test_fewer_than_three_steady_cycles_give_no_held_out_error():
    truth = model(3, seed=1)
    x = sweep([30e-6] * 3)
    fit = fit_maxwell_slip(truth.voltage(x), x, [slice(400, 800), slice(800, 1200)])
    assert np.isnan(fit.feedforward).all() and np.isnan(fit.forward).all()
    assert "no held-out error" in fit.note


@pytest.fixture(scope="module")
def twin_record(stack_params):
    """Nine cycles of a 1 Hz, 0–100 V raised sine through the twin's stack, the laser's reading
    rounded to its resolution (Table 2.1); the first cycle is the start-up."""
    t = np.arange(int(9 * FS)) / FS
    u = 50.0 * (1 - np.cos(2 * np.pi * t))
    kc = K.kernel_constants(stack_params, FS)
    out = K.run(
        u,
        np.zeros_like(u),
        np.full_like(u, stack_params.thermal.T_amb),
        kc,
        K.initial_state(kc, stack_params.thermal.T_amb),
    )
    x = out[:, K.OUTPUTS.index("x")]
    resolution = stack_params.instruments.laser_resolution
    x = np.round(x / resolution) * resolution
    per = int(FS)
    return u, x, [slice(i * per, (i + 1) * per) for i in range(1, 9)]


def test_on_the_twin_the_feedforward_error_is_within_1p5_of_the_twins_own(
    stack_params, twin_record
):
    """The identified model's compensator on held-out cycles against the twin's own
    rate-independent model's (both miss the twin's creep and viscous drop); and far below the
    linear compensator U = k·x/α, which leaves the whole loop."""
    u, x, cycles = twin_record
    fit = fit_maxwell_slip(u, x, cycles)
    test = np.concatenate([np.arange(c.start, c.stop) for c in cycles[2::3]])
    own = twin_voltage(stack_params, x)[test] - u[test]
    own_rms = 100 * np.sqrt(np.mean(own**2)) / fit.drive_span
    linear = stack_params.stack.k / stack_params.stack.alpha * x[test] - u[test]
    linear_rms = 100 * np.sqrt(np.mean(linear**2)) / fit.drive_span
    assert fit.feedforward[0] <= 1.5 * own_rms
    assert fit.feedforward[0] < linear_rms / 5
    assert 2 <= fit.model.order <= 12
    # the forward prediction is as good as the compensator (both on the same held-out cycles)
    assert fit.forward[0] < linear_rms / 5


def test_on_a_twin_capture_the_characterised_model_does_as_well(tmp_path, stack_params, stack_daq):
    """The same through a capture of the twin's bench (its instruments: the laser's resolution
    and drift, the drive's noise, the DAQ's 16 bits) and characterise's reduction and cycles."""
    # twelve cycles: the first few are the start-up of the twin's creep, a warm-up
    drive = Drive("voltage", (Segment(12.0, 1.0, 0.0, 100.0),))
    path = simulate_capture(tmp_path / "sine.nc", stack_params, stack_daq, drive, {}, 7, "s").path
    reduced, channel, warmup = reduce_capture(path)
    cycles = steady_cycles(reduced, channel, period_s=1.0, warmup_s=warmup)
    u, x = reduced.data["U"], reduced.data[channel]
    fit = fit_maxwell_slip(u, x, cycles.used)
    test = np.concatenate([np.arange(c.start, c.stop) for c in cycles.used[2::3]])
    own = twin_voltage(stack_params, x)[test] - u[test]
    assert fit.cycles[2] >= 2
    assert fit.feedforward[0] <= 1.5 * 100 * np.sqrt(np.mean(own**2)) / fit.drive_span
