"""The twin's signal chain between the command and the capture (workflow/unknowns.yaml's group
"signal chain"): each value its manifest key gives does what it says, against closed forms, and
the nominal values are the ideal chain's."""

import dataclasses

import numpy as np
import pytest
import scipy.signal
from hypothesis import given, settings
from hypothesis import strategies as st

from selfsense.io.capture import channel_spec
from selfsense.twin.bench import Bench, experiment_seed
from selfsense.twin.instruments import Amplifier

from ..tolerances import CLOSED_FORM, assert_close, rtol


@settings(max_examples=30, deadline=None)
@given(gain=st.floats(0.3, 0.999), ns=st.sampled_from([6, 12, 24]))
def test_the_amplifier_passes_its_gain_at_the_folded_ripple_and_the_drive_whole(gain, ns):
    """The first-order amplifier's discrete gain at fs/ns is the declared one (the bilinear map
    pre-warped there), and a slow drive (10 Hz) passes to within the first-order roll-off."""
    fs = 48e3
    amp = Amplifier(gain, fs, ns)
    _, (h_fold, h_slow) = scipy.signal.freqz(amp.b, amp.a, [fs / ns, 10.0], fs=fs)
    assert_close(abs(h_fold), gain, rtol(1.0 / (1.0 - gain**2), roundings=60))
    corner = (fs / ns) * gain / np.sqrt(1 - gain**2)  # analogue corner, within the warp
    assert 1 - abs(h_slow) <= (10.0 / corner) ** 2  # 1 − |H| ≈ (f/f_c)²/2


def test_the_ideal_amplifier_hands_the_command_on_untouched():
    command = np.linspace(-30.0, 100.0, 50)
    assert Amplifier(1.0, 48e3, 12)(command) is command


def test_an_amplifier_short_of_unity_needs_the_folding_plan():
    with pytest.raises(ValueError, match="ns"):
        Amplifier(0.5, 48e3, None)


@settings(max_examples=30, deadline=None)
@given(bits=st.integers(8, 16), values=st.lists(st.floats(-250.0, 250.0), min_size=1))
def test_an_adc_of_fewer_bits_reports_its_own_grid_in_the_int16_codes(bits, values):
    """A b-bit ADC's values are multiples of 2^(16 − b) int16 codes (so the capture stores them
    exactly), clipped to its own full scale, and never farther than half its step from the input
    inside the range."""
    spec = channel_spec("U", -200.0, 200.0, bits=bits)
    q = spec.quantize(np.array(values))
    codes, _ = spec.pack(q)
    assert np.all(codes % 2 ** (16 - bits) == 0)
    inside = np.abs(np.array(values)) <= 200.0 - spec.step
    err = np.abs(q - np.array(values))[inside]
    assert np.all(err <= spec.step / 2 * (1 + CLOSED_FORM))
    assert np.abs(q).max() <= 200.0


def test_the_current_probe_s_gain_at_the_ripple_scales_the_ripple_current(stack_params, stack_daq):
    """With the drive at rest, the noise and the ADC out of the way (a 200 A range, no noise), Ir
    is the ripple current through the high-pass: a probe gain g scales it by g."""
    ins = dataclasses.replace(stack_params.instruments, ripple_noise_I=0.0)
    t = np.arange(4800) / stack_daq.fs
    ir = {}
    for gain in (1.0, 0.97):
        params = dataclasses.replace(
            stack_params,
            instruments=dataclasses.replace(ins, I_probe_gain_at_ripple=gain),
        )
        bench = Bench(params, stack_daq, experiment_seed(1, "probe"))
        bench.adc.pop("Ir")  # recorded as it is, not on the ADC's grid
        ir[gain] = bench.step(t, np.zeros(len(t)))[0]["Ir"]
    assert np.ptp(ir[1.0]) > 0.01  # the ripple current is there
    assert_close(ir[0.97], 0.97 * ir[1.0], rtol(1.0, roundings=40), atol=1e-18)


def test_the_drifts_move_at_their_declared_bandwidths(stack_params, stack_daq):
    """The probe offset's and the laser's slow drifts are sums of sinusoids below their keys'
    bandwidths (each term at 5–100 % of it)."""
    ins = dataclasses.replace(
        stack_params.instruments, I_offset_drift_bandwidth=0.01, laser_drift_bandwidth=0.002
    )
    bench = Bench(
        dataclasses.replace(stack_params, instruments=ins), stack_daq, experiment_seed(2, "d")
    )
    for process, bandwidth in ((bench.offset_drift, 0.01), (bench.laser_drift, 0.002)):
        assert np.all((process.freqs >= 0.05 * bandwidth) & (process.freqs <= bandwidth))
