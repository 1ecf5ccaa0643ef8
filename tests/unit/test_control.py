"""Chapter 6: the integral loop's gains and transfer function, and the real-time controller."""

import numpy as np
import pytest

from selfsense.chapters.ch6 import errors, segment_maxima, segment_windows, table_6_1
from selfsense.methods.control import IntegralController, tracking_prediction
from selfsense.twin.closed_loop import HPOIntegralController

from ..tolerances import CLOSED_FORM


def test_gain_and_loop_shape():
    g = IntegralController(2 * np.pi * 250, 2.68e6)
    assert g.K_I == pytest.approx(2 * np.pi * 250 * 2.68e6)
    T = g.tracking()
    assert abs(T(0)) == pytest.approx(1.0)  # Type-I: no steady error to a constant reference
    assert abs(T(2j * np.pi * 250)) == pytest.approx(
        1 / np.sqrt(2), rel=CLOSED_FORM
    )  # crossover at ω_C


def test_tracking_prediction_at_125_hz():
    table = tracking_prediction(IntegralController(2 * np.pi * 250, 2.68e6), [125.0], 15e-6)
    assert table["phase lag [deg]"].iloc[0] == pytest.approx(np.degrees(np.arctan(0.5)))
    assert table["predicted error amplitude [µm]"].iloc[0] == pytest.approx(
        15 * 0.5 / np.sqrt(1.25)
    )


class FakeChain:
    """Returns a fixed estimate: isolates the controller's integration."""

    def __init__(self, x_hat):
        self.x_hat = x_hat

    def process(self, ur, ir, current):
        return {"x_hat": np.full(len(ur), self.x_hat)}


def test_controller_integrates_per_sample_with_one_block_delay():
    fs, block = 48000.0, 12
    gains = IntegralController(1000.0, 2e6)
    ctl = HPOIntegralController(
        FakeChain(0.0), gains, lambda t: np.full(len(t), 1e-6), fs, block, engage_at=0.0
    )
    t0 = np.arange(block) / fs
    u0 = ctl.command(t0)
    assert np.all(u0 == 0)  # nothing observed yet
    ctl.observe(t0, {"Ur": t0, "Ir": t0, "I": t0})
    u1 = ctl.command(t0 + block / fs)
    step = gains.K_I * 1e-6 / fs
    np.testing.assert_allclose(u1, step * np.arange(1, block + 1))  # a ramp, not a staircase
    ctl.u = 1e9
    assert ctl.command(t0)[-1] == 120.0  # held at the amplifier limit


def test_segment_maxima_and_table_6_1():
    t = np.linspace(0, 0.8, 801)
    x_ref = np.repeat([30e-6, 5e-6, 25e-6, 10e-6, 20e-6, 15e-6, 28e-6, 2e-6], 100)[: len(t)]
    x_ref = np.append(x_ref, [2e-6] * (len(t) - len(x_ref)))
    errs = errors(x_ref, x_ref - 1e-6, x_ref - 0.5e-6, closed=True)
    windows = segment_windows({"segments": [{"duration": 0.1}] * 8}, omega_c=5 / 0.01)
    assert [w[0] for w in windows] == list("abcdefgh") and windows[1][1:] == pytest.approx(
        (0.11, 0.2)
    )
    maxima = segment_maxima(t, errs, windows)
    assert maxima["e_TCL"] == pytest.approx([1e-6] * 8)
    assert maxima["e_OCL"] == pytest.approx([0.5e-6] * 8)
    table = table_6_1({"e_TCL": [maxima["e_TCL"]] * 3, "e_OCL": [maxima["e_OCL"]] * 3})
    row = table[(table["error"] == "e_TCL") & (table["statistic"] == "mean")].iloc[0]
    assert row["a [µm]"] == pytest.approx(1.0) and row["thesis a [µm]"] == 0.45
