"""The closed loop's drive in the ripple channels (selfsense.verify.loop_leak): the twin's what-if keeps the
drive out of the ripple channels and touches nothing else, and on the smoke run the study's
as-simulated ε_OCL is Table 6.2's while the leak-free run's C_e is the less biased."""

import numpy as np
import pandas as pd
import pytest

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


@pytest.mark.slow
def test_smoke_study_measures_the_campaigns_capture_and_a_leak_free_one(smoke_run):
    res = smoke_run / "results/pi_p885"
    study = pd.read_csv(res / "twin/loop_leak.csv").set_index("run")
    t62 = pd.read_csv(res / "ch6/table_6_2.csv").set_index(["profile", "error"])
    audit = (
        pd.read_csv(res / "ch6/audit.csv").set_index("run")["max |offline − logged| [nm]"] * 1e-3
    )
    assert sorted(study.index) == [f"ch6_p2{p}_closed" for p in "abcd"]
    for run, row in study.iterrows():
        table = t62.loc[("P" + run.split("_")[1][1:], "e_OCL"), "max [µm]"]
        # the study's budget runs the offline chain, the table reads the logged estimate: the audit's margin
        assert abs(row["max |ε_OCL| [µm], as simulated"] - table) <= audit[run] + 1e-9 * table, run
        assert abs(row["C_e error mean [%], no drive leak"]) < abs(
            row["C_e error mean [%], as simulated"]
        ), run
    assert not (smoke_run / "results/tokin_nb40/twin/loop_leak.csv").exists()
    # Table 6.2's P2 ε_OCL rows, in µm and in % of stroke, quote the study
    card = pd.read_csv(res / "scorecard.csv")
    quoting = card[card["note"].str.contains("Measured (twin/loop_leak.csv", regex=False, na=False)]
    assert sorted(quoting["quantity"]) == sorted(
        f"P2{p}, ε_OCL{unit}" for p in "abcd" for unit in ("", ", % of stroke")
    )
