"""The closed loop's drive in the ripple channels (selfsense.verify.loop_leak): the twin's what-if
keeps the drive out of the ripple channels and touches nothing else. On the smoke run the study's
as-simulated ε_OCL is Table 6.2's while the leak-free run's C_e is the less biased:
tests/workflow/test_verify_tables.py."""

import numpy as np

from selfsense.twin.bench import Bench, experiment_seed
from selfsense.twin.instruments import HighPass


def test_a_bench_without_the_drive_leak_records_the_ripple_channels_less_the_leak(
    stack_params, stack_daq
):
    t = np.arange(int(0.02 * stack_daq.fs)) / stack_daq.fs
    U = (
        np.clip((t - 0.005) / 5e-3, 0.0, 1.0) * 20.0
    )  # a 5 ms ramp to 20 V: its slope leaks through the high-pass
    seed = experiment_seed(3, "leak")
    leaky, _ = Bench(stack_params, stack_daq, seed).step(t, U)
    clean, truth = Bench(stack_params, stack_daq, seed, drive_leak=False).step(t, U)
    for channel in (
        "U",
        "I",
        "x_laser",
        "F",
    ):  # the same noise draws: only the ripple channels differ
        np.testing.assert_array_equal(leaky[channel], clean[channel])
    leak = HighPass(stack_params.ripple.highpass_hz, stack_daq.fs).leak(U)
    # each record is rounded to the ADC's step: their difference is the leak to one step
    step = Bench(stack_params, stack_daq, seed).adc["Ur"].scale_factor
    np.testing.assert_allclose(leaky["Ur"] - clean["Ur"], leak, rtol=0, atol=step)
    assert np.max(np.abs(leak)) > 100 * step
