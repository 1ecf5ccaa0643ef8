"""Ronkanen's Section 7 results on the twin's truth (selfsense.verify.powerloss_truth): a perfect
sensor has no share, and a sensor offset drifting by a known amount has exactly that share. The
smoke run's measured column is the performance table's: tests/workflow/test_verify_tables.py."""

import numpy as np
import pytest

from selfsense.chapters.ronkanen import CONTROLS, Record, performance
from selfsense.verify.powerloss_truth import SENSOR, performance_truth

FS, A_CMD = 100.0, 1.0e3
HOLD_START, HOLD = 20.0, 120.0
I_RAMP = 1e-6  # [A]


def record(kind, control, drift=0.0):
    """A run whose displacement is a_cmd·∫i exactly, read by a sensor whose offset grows by
    ``drift`` [m/s]. The repeated and decaying ramps are triangles; the drift run ramps up from 2 s
    to 12 s and holds, so its true drift is 0 and the unloaded zero (the first second) is 0."""
    t = np.arange(int((HOLD_START + HOLD + 10) * FS)) / FS
    if kind == "drift":
        i_cmd = np.where((t >= 2) & (t < 12), I_RAMP, 0.0)
    else:
        i_cmd = np.where((t // 5) % 2 == 0, I_RAMP, -I_RAMP)
    x = A_CMD * np.cumsum(i_cmd) / FS
    U = x / A_CMD / 1e-7 if control == "voltage" else np.zeros_like(t)
    i = i_cmd if control == "current" else np.zeros_like(t)
    return Record(f"{kind}_{control}", t, U, i, i, x + drift * t, control, "model_10", np.inf)


def runs(drift=0.0):
    return {k: {c: record(k, c, drift) for c in CONTROLS} for k in ("decay", "repeat", "drift")}


def test_a_perfect_sensor_has_no_share_and_a_drifting_one_its_own():
    true = runs()
    true_x = {r.name: r.x for recs in true.values() for r in recs.values()}
    clean = performance_truth(true, true_x, A_CMD, HOLD_START, HOLD)
    assert (clean[SENSOR] == 0).all()
    assert (
        clean["measured"].tolist()
        == performance(*true.values(), A_CMD, HOLD_START, HOLD)["value"].tolist()
    )
    d = 1e-9
    drifting = performance_truth(runs(drift=d), true_x, A_CMD, HOLD_START, HOLD).set_index(
        ["measure", "control"]
    )
    # the hold's position from 20.5 s to 139.5 s (1 s means) against the held stroke above the
    # zero's: the sensor moves it by 119 s·d, and its held position by 20 s·d; a window's mean time
    # is off by at most half a sample (0.005 s) of those
    held = A_CMD * I_RAMP * 10.0
    for control in CONTROLS:
        row = drifting.loc[("drift over the hold [%]", control)]
        assert row["true x"] == 0.0
        assert row[SENSOR] == pytest.approx(100 * 119 * d / (held + 20 * d), rel=0.005 / 119)
    np.testing.assert_array_equal(drifting["measured"] - drifting["true x"], drifting[SENSOR])
