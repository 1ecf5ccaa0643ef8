"""The characterisation of one capture (selfsense.chapters.characterise) measured on its steady
cycles: its row, its headings with the channels' declared scalings, its loop figure, the rules'
scripts; and, on a clean steady sine, the same numbers as before it measured cycles.

The recordings here are an ellipse-shaped loop x = a·B·(1 − cos(θ − δ)) on the drive
U = a·A·(1 − cos θ) (loop width 100·sin δ % of its stroke 2aB), with the amplitude a ramped and
paused and x settling, as the cycle tests (tests/unit/test_cycles.py) do with a Maxwell-slip
actuator.
"""

import json

import numpy as np
import pandas as pd
import pytest

from selfsense.chapters import characterise as ch
from selfsense.io.capture import CaptureWriter, channel_spec
from selfsense.methods.cycles import find_cycles

from ..helpers import LAB_A, LAB_B, LAB_PHI, PAGE_SETTINGS, bench_manifest, ellipse, script

FS, F, A, B, WIDTH = 500.0, 2.0, 60.0, 12e-6, 0.1  # Hz, Hz, V, m, sin δ
STROKE_HEADING, WIDTH_HEADING = "stroke [µm]", "x–U loop width [% of stroke]"
GAIN_HEADING = "gain (least squares) [µm/V]"
#: the drive amplitude per cycle (of A), 0 a pause of a cycle
SCHEDULE = [1.0] * 5 + [0.7, 0.4, 0.0, 0.0, 0.5, 0.8] + [1.0] * 6


def recording(schedule=SCHEDULE, settle=3e-6, noise=5e-4, seed=0):
    """(u [V], x [m]) at FS: per cycle its amplitude a, u = a·A·(1 − cos θ) from 0 V, x =
    a·B·(1 − cos(θ − δ)) settling from ``settle`` below the loop (τ = 0.05 s), noise of
    ``noise`` × A and × B."""
    per = int(FS / F)
    theta = 2 * np.pi * np.arange(per * len(schedule)) / per
    a = np.repeat(np.asarray(schedule, float), per)
    t = np.arange(len(theta)) / FS
    u = a * A * (1 - np.cos(theta))
    x = a * B * (1 - np.cos(theta - np.arcsin(WIDTH))) - settle * np.exp(-t / 0.05)
    rng = np.random.default_rng(seed)
    return u + noise * A * rng.standard_normal(len(u)), x + noise * B * rng.standard_normal(len(u))


def capture(path, u, x, current=None, **attrs):
    """A capture in the contract of U, x_laser (and I) at FS."""
    specs = [channel_spec("U", -200.0, 200.0), channel_spec("x_laser", -1e-4, 1e-4)]
    data = {"U": u, "x_laser": x}
    if current is not None:
        specs.append(channel_spec("I", -2.0, 2.0))
        data["I"] = current
    base = {"fs": FS, "dataset": "lab", "experiment": path.stem, "source": "measured"}
    with CaptureWriter(path, base | attrs, specs, len(u)) as w:
        w.write(data)
    return path


# -- a clean steady sine: the numbers it had before ------------------------------------------------


@pytest.mark.parametrize("periods", [3, 10])
def test_a_clean_steady_sine_keeps_its_stroke_loop_width_gains_and_nonlinearity(periods):
    t, u, x = ellipse(periods)
    fs = 1 / (t[1] - t[0])
    old = ch.loop_measures(u, x, ch.rising(u))
    reduced = ch.Reduced(fs, {"U": u, "x_laser": x})
    new = ch.characterise(reduced, "x_laser", 0.1, 1.0)
    assert new["cycles_used"] == periods and new["stroke"] == pytest.approx(old["stroke"], rel=1e-3)
    assert new["loop_width"] == pytest.approx(old["loop_width"], abs=0.2)
    assert new["loop_width"] == pytest.approx(100 * np.sin(LAB_PHI), abs=0.2)
    for key in ("gain_ls", "gain_end"):
        assert new[key] == pytest.approx(old[key], rel=5e-3)
    assert new["gain_ls"] == pytest.approx(LAB_B * np.cos(LAB_PHI) / LAB_A, rel=5e-3)
    assert new["nonlinearity"] == pytest.approx(old["nonlinearity"], abs=0.05)


def test_cycles_too_coarse_to_measure_alone_are_measured_together():
    # 17.3 block means a cycle (a 100 Hz drive in a long capture's 1.7 kHz): the peaks and the
    # loop's middle fall between a cycle's samples, but not between all the cycles' together
    fs, period = 1730.0, 0.01
    t = np.arange(int(5 * fs)) / fs
    u = 60 + 60 * np.sin(2 * np.pi * t / period)
    x = 12e-6 + 12e-6 * np.sin(2 * np.pi * t / period - np.arcsin(WIDTH))
    out = ch.characterise(ch.Reduced(fs, {"U": u, "x_laser": x}), "x_laser", 0.1, 1.0)
    assert "17 samples a cycle: stroke and loop width of the used cycles together" in out["note"]
    assert out["stroke"] == pytest.approx(24e-6, rel=0.01)
    assert out["loop_width"] == pytest.approx(100 * WIDTH, abs=0.5)
    assert "stroke_min" not in out and out["cycles_used"] == 500


# -- a capture with a warm-up, ramps and a pause ---------------------------------------------------


def test_the_row_of_a_ramped_paused_settling_capture_is_its_steady_cycles(tmp_path):
    u, x = recording()
    row, panels, _ = ch.characterise_capture(capture(tmp_path / "ramped.nc", u, x), 0.1, 1.0)
    assert list(row) == ch.TABLE_COLUMNS
    # 2B, 100·sin δ: within the ADC's steps and the noise
    assert row[STROKE_HEADING] == pytest.approx(2 * B * 1e6, rel=0.01)
    assert row[WIDTH_HEADING] == pytest.approx(100 * WIDTH, abs=0.5)
    assert (
        row["stroke, least cycle [µm]"] <= row[STROKE_HEADING] <= row["stroke, largest cycle [µm]"]
    )
    assert row["drive period [s]"] == pytest.approx(1 / F, rel=1e-3)
    assert row["period from"] == "drive" and row["warm-up from"] == "detected"
    assert row["drive amplitude, used cycles [V]"] == pytest.approx(A, rel=0.01)
    # cycles from upward crossing to upward crossing, a quarter into each: the quarter before
    # the first and the first whole cycle settling (warm-up); 5 + 5 full; 0.7 and 0.5, 0.8 minor;
    # the 0.4 cycle and the two at rest one pause; the last three quarters partial
    assert row["cycles used"] == 9
    assert row["cycles dropped: warm-up"] == 2
    assert row["cycles dropped: minor"] == 3 and row["cycles dropped: pause"] == 1
    assert row["cycles dropped: partial"] == 1 and row["cycles dropped: irregular"] == 0
    amplitudes = [float(a) for a in row["minor loops' drive amplitudes [V]"].split(", ")]
    np.testing.assert_allclose(amplitudes, [0.7 * A, 0.5 * A, 0.8 * A], atol=0.05 * A)
    assert "9 cycles used, 7 dropped (2 warm-up, 1 partial, 1 pause, 3 minor)" in row["note"]
    assert "3 minor loops" in row["note"]
    # the loop figure: each kind of cycle's samples marked, the title counting them
    assert panels.name == "ramped: 9 cycles used, 7 dropped"
    groups = panels.panels[0][4]
    used, colour = groups["used (9)"]
    assert colour == "C0" and abs(used.sum() - 9 * int(FS / F)) <= 9
    assert {"warm-up (2)", "minor (3)", "pause (1)", "partial (1)"} <= set(groups)


def test_the_old_numbers_of_the_same_capture_were_the_settling_and_the_blend(tmp_path):
    u, x = recording()
    old = ch.loop_measures(u, x, ch.rising(u))
    assert old["stroke"] / (2 * B) - 1 > 0.1  # from the settling's 3 µm below the loop
    cycles = find_cycles(u, FS, x)
    new = ch.characterise(ch.Reduced(FS, {"U": u, "x_laser": x}), "x_laser", 0.1, 1.0, cycles)
    assert abs(new["stroke"] / (2 * B) - 1) < 0.01


def test_the_capture_attribute_warmup_and_a_protocol_period_are_used(tmp_path):
    u, x = recording()
    path = capture(tmp_path / "attr.nc", u, x, warmup_s=1.0)
    row, _, _ = ch.characterise_capture(path, 0.1, 1.0, period_s=1 / F)
    assert row["warm-up [s]"] == 1.0 and row["warm-up from"] == "capture attribute warmup_s"
    assert row["cycles dropped: warm-up"] == 3 and row["cycles used"] == 8
    assert row["period from"] == "protocol" and row["drive period [s]"] == 1 / F
    assert "warm-up 1 s (capture attribute warmup_s)" in row["note"]


def test_steps_are_measured_over_all_samples_and_say_so(tmp_path):
    levels = np.repeat([10.0, 80.0, 30.0, 100.0, 50.0], int(1.5 * FS))
    x = 2e-7 * levels
    row, panels, _ = ch.characterise_capture(capture(tmp_path / "steps.nc", levels, x), 0.1, 1.0)
    assert row["period from"] == "no periodic drive" and np.isnan(row["cycles used"])
    assert row["note"].startswith("no periodic drive") and "over all samples" in row["note"]
    assert row[STROKE_HEADING] == pytest.approx(1e6 * np.ptp(x), rel=1e-3)
    assert row[GAIN_HEADING] == pytest.approx(0.2, rel=1e-3)
    assert panels.name == "steps: no periodic drive, all samples"


def test_the_current_gives_its_charge_measures_on_the_used_cycles(tmp_path):
    u, x = recording(noise=0.0)
    capacitance = 2e-6
    current = capacitance * np.gradient(u) * FS
    path = capture(tmp_path / "charged.nc", u, x, current=current)
    row, panels, _ = ch.characterise_capture(path, 0.1, 1.0)
    assert row["q–U slope [µF]"] == pytest.approx(1e6 * capacitance, rel=0.02)
    assert len(panels.panels) == 2 and panels.panels[1][4] is panels.panels[0][4]


# -- headings and axes with the channels' declared scalings --------------------------------------


SCALINGS = {"U": "20 × logged (gain)", "x_laser": "0.5 × logged"}


def test_headings_and_axes_show_the_channels_declared_scaling(tmp_path):
    u, x = recording()
    path = capture(tmp_path / "scaled.nc", u, x)
    row, panels, model = ch.characterise_capture(path, 0.1, 1.0, scalings=SCALINGS)
    units = {p["parameter"]: p["unit"] for p in model}
    assert (
        units["u0"] == "V; U = 20 × logged (gain)" and units["r_1"] == "µm; x_laser = 0.5 × logged"
    )
    assert units["c0"] == "V/µm; U = 20 × logged (gain); x_laser = 0.5 × logged"
    assert "gain (least squares) [µm/V; x_laser = 0.5 × logged; U = 20 × logged (gain)]" in row
    assert "stroke [µm; x_laser = 0.5 × logged]" in row
    assert "drive amplitude, used cycles [V; U = 20 × logged (gain)]" in row
    assert WIDTH_HEADING in row  # a ratio: no scaling of its own
    assert [ch.plain_heading(k) for k in row] == ch.TABLE_COLUMNS
    _, _, xlabel, ylabel, _ = panels.panels[0]
    assert xlabel == "U [V] (20 × logged (gain))" and ylabel == "x_laser [µm] (0.5 × logged)"
    plain, _, _ = ch.characterise_capture(path, 0.1, 1.0)
    for a, b in zip(row.values(), plain.values()):  # the same values, headed otherwise
        assert a == b or (a != a and b != b)


def test_the_table_heads_each_column_as_its_rows_do():
    rows = [
        ch.row("a", {"stroke": 1e-5}, "x_laser", 1000.0, scalings=SCALINGS),
        ch.row("b", {"stroke": 2e-5}, "x_laser", 1000.0, scalings=SCALINGS),
    ]
    columns = ch.table_columns(rows)
    assert "stroke [µm; x_laser = 0.5 × logged]" in columns and "stroke [µm]" not in columns
    assert len(columns) == len(ch.TABLE_COLUMNS)
    assert ch.table_columns([ch.row("c", {}, "x_laser", 1.0)]) == ch.TABLE_COLUMNS
    assert ch.heading("hold [s]", (), "x_laser", SCALINGS) == "hold [s]"
    assert ch.plain_heading("q–U slope [µF; I = 2 × probe; U = 20 × logged]") == "q–U slope [µF]"


# -- the rules' scripts ----------------------------------------------------------------------------


def test_the_scripts_pass_periods_and_scalings_and_draw_dropped_cycles_on_top(tmp_path):
    from matplotlib import pyplot as plt  # after selfsense.chapters.figures chose Agg

    u, x = recording()
    path = capture(tmp_path / "run_1.nc", u, x)
    rows_json, figure = tmp_path / "page_01.json", tmp_path / "loops_01.png"
    page = script("characterise_page")
    page.main(
        [str(path)],
        str(rows_json),
        str(figure),
        "lab (1 of 1)",
        **PAGE_SETTINGS
        | {"periods": {"run_1": 1 / F}, "scalings": SCALINGS}
        | {"cycle_rules": {"full_tolerance": 0.05}},
        inputs=[str(path)],
    )
    row = json.loads(rows_json.read_text())["rows"][0]
    assert row["period from"] == "protocol" and "stroke [µm; x_laser = 0.5 × logged]" in row
    assert figure.exists()
    table = tmp_path / "summary.csv"
    script("characterise").main(
        bench_manifest(tmp_path),
        [str(rows_json)],
        str(table),
        str(tmp_path / "instruments.csv"),
        str(tmp_path / "hysteresis_model.csv"),
        inputs=[str(rows_json)],
    )
    written = pd.read_csv(table)
    assert list(written.columns) == ch.table_columns([row])
    # the figure draws the used cycles first and each kind of dropped cycle on top of them in
    # its own colour, with a legend naming them
    fig = ch.loop_page([ch.characterise_capture(path, 0.1, 1.0)[1]], "page")
    lines = fig.axes[0].lines
    assert lines[0].get_color() == "C0" and lines[0].get_label() == "used (9)"
    above = lines[1:]
    assert above and all(line.get_zorder() > lines[0].get_zorder() for line in above)
    assert len({line.get_color() for line in lines}) == len(lines)
    legend = [text.get_text() for text in fig.axes[0].get_legend().get_texts()]
    assert legend == [line.get_label() for line in lines] and "warm-up (2)" in legend
    plt.close(fig)
