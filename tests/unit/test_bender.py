"""The bender twin (Ronkanen 2002): physics, current loop, kernel vs reference, captures, and the
analysis run on the twin's records in-process (parameter recovery, current vs voltage control)."""

import dataclasses

import numpy as np
import pytest

from selfsense.chapters import ronkanen
from selfsense.io.capture import open_capture
from selfsense.io.manifest import (
    ManifestError,
    expand_protocols,
    load_config,
    load_dataset,
    validate_document,
)
from selfsense.methods import powerloss as pl
from selfsense.methods.drive import Drive, Segment, drive_from_protocol
from selfsense.twin import bender as B
from selfsense.twin.bench import experiment_seed
from selfsense.twin.experiment import daq_plan, simulate_experiment

from ..helpers import ROOT
from ..tolerances import CLOSED_FORM, rtol

MANIFEST = load_dataset(ROOT / "raw", "tokin_nb40")
PARAMS = B.BenderParams.from_manifest(MANIFEST["twin"])
FS = float(MANIFEST["daq"]["fs"])
EQ15 = B.Compensation("model_10", R=21e9, c=3.4e7)
#: an identification's Eq 15 setting, on purpose not the twin's R and c (21 GΩ, 3.4e7 1/A)
IDENTIFIED = {"R": 2.2e10, "c": 3.3e7}


def run(drive: Drive, params=PARAMS, compensation=B.Compensation(), seed=0, name="test"):
    """One run of the bench in memory: (Record of the measured channels, truth states)."""
    bench = B.BenderBench(params, FS, experiment_seed(seed, name), compensation)
    t = np.arange(int(round(drive.duration * FS))) / FS
    measured, truth = bench.step(t, drive.quantity, drive(t))
    rec = ronkanen.Record(
        name,
        t,
        measured["U"],
        measured["I"],
        measured["i_cmd"],
        measured["x_disp"],
        drive.quantity,
        compensation.kind,
        compensation.X,
    )
    return rec, truth


def run_experiment(name, campaign="thesis", seed=0, identified=None):
    """One catalogue experiment in memory; ``identified``: the R and c an Eq 15 run takes."""
    exp = expand_protocols(["ronkanen"], campaign)[name]
    return run(
        drive_from_protocol(exp.protocol),
        compensation=B.compensation_of(exp, identified),
        seed=seed,
        name=name,
    )


def current(*steps):
    """A current drive from (duration [s], i_c [A]) steps."""
    return Drive("current", tuple(Segment(d, hi=i) for d, i in steps))


# ---------------------------------------------------------------------------------------------
# Physics and bench
# ---------------------------------------------------------------------------------------------
def test_static_hold_reaches_about_105_V_and_then_holds():
    _, truth = run_experiment("rk_static_hold")
    end_of_charge = int(40 * FS) - 1
    assert 95.0 <= truth["V"][end_of_charge] <= 115.0  # Section 4: 105 V
    assert 150e-6 <= truth["x"][end_of_charge] <= 200e-6  # Fig 2
    hold = truth["x"][int(60 * FS) :]
    assert np.ptp(hold) < 1e-6


def test_at_rest_the_loss_impedance_is_the_leakage_resistance():
    drive = Drive("voltage", (Segment(2.0, 0.25, 0.0, 100.0), Segment(900.0, hi=100.0)))
    _, truth = run(drive)
    # creep has settled (τ = 60 s), nothing charges: the whole current leaks through R
    assert truth["I"][-1] == pytest.approx(100.0 / PARAMS.actuator.R, rel=1e-3)
    assert truth["X"][-1] == pytest.approx(PARAMS.actuator.R, rel=1e-6)


def test_moving_lowers_the_loss_impedance_as_model_10():
    _, truth = run(current((30.0, 300e-9)))
    moving = slice(int(10 * FS), None)
    expected = PARAMS.actuator.R / np.sqrt((PARAMS.actuator.c * truth["i_C"][moving]) ** 2 + 1)
    # the same closed form evaluated twice (float64; the capture stores it as float32 only in
    # /truth, which these arrays are not)
    np.testing.assert_allclose(truth["X"][moving], expected, rtol=CLOSED_FORM)
    # i_l·X = V holds to the kernel's root solve (≤ 4ε of V) and the product's rounding
    np.testing.assert_allclose(
        truth["i_l"][moving] * truth["X"][moving], truth["V"][moving], rtol=float(rtol(4.0))
    )
    assert truth["X"][moving].max() < 0.2 * PARAMS.actuator.R


def test_open_loop_voltage_control_shows_the_papers_hysteresis_and_creep():
    """Calibration bands of the twin's physics (Section 8: 27 % and 15 %)."""
    rec, _ = run_experiment("rk_decay_voltage")
    required = rec.required(a_cmd=np.nan)
    assert 20.0 <= pl.branch_hysteresis_percent(required, rec.x, 0.05 * np.ptp(required)) <= 35.0
    held, _ = run_experiment("rk_drift_voltage")
    assert 10.0 <= pl.drift_percent(held.t, held.x, 40.0, 120.0) <= 20.0


@pytest.mark.parametrize("X_trial, trend", [(10e9, "slows"), (1e9, "speeds up")])
def test_trial_compensation_bends_the_ramp_velocity_as_figs_3_and_4(X_trial, trend):
    """Too large an X leaves loss uncompensated: the speed falls as the charge grows (Fig 3,
    curve 1); too small an X over-compensates and the speed grows (Fig 4)."""
    rec, _ = run(current((50.0, 300e-9)), compensation=B.Compensation("impedance", X=X_trial))
    v = pl.ramp_velocity(rec.t, rec.x, 2.0)
    early, late = np.mean(v[int(5 * FS) : int(15 * FS)]), np.mean(v[int(38 * FS) : int(48 * FS)])
    assert (late < 0.97 * early) if trend == "slows" else (late > 1.03 * early)


def test_current_loop_gain_follows_the_design_rule():
    """Into a capacitance the PID's integral gain is a proportional current gain K = C·G·ki:
    the meter settles at K/(1 + K) of the setpoint (hysteresis and creep switched off)."""
    linear = dataclasses.replace(
        PARAMS,
        hysteresis=dataclasses.replace(PARAMS.hysteresis, v_total=1e-9),
        creep=dataclasses.replace(PARAMS.creep, C=(1e3,)),
    )
    rec, _ = run(current((5.0, 300e-9)), params=linear)
    K = PARAMS.actuator.C * PARAMS.amplifier.gain * PARAMS.pid.ki
    assert np.mean(rec.I[int(3 * FS) :]) == pytest.approx(300e-9 * K / (1 + K), rel=0.01)


def test_amplifier_output_saturates():
    _, truth = run(Drive("voltage", (Segment(1.0, hi=500.0),)))
    assert truth["V"].max() == pytest.approx(PARAMS.amplifier.gain * PARAMS.amplifier.u_max)


# ---------------------------------------------------------------------------------------------
# Kernel against the plain-Python reference
# ---------------------------------------------------------------------------------------------
CASES = [
    (
        "current",
        B.Compensation(),
        np.r_[np.full(300, 300e-9), np.full(500, -550e-9), np.full(200, 5e-9)],
    ),
    (
        "current",
        B.Compensation("impedance", X=2e9),
        np.r_[np.full(400, 300e-9), np.full(400, -300e-9)],
    ),
    ("current", EQ15, np.r_[np.full(400, 450e-9), np.full(300, -150e-9), np.zeros(300)]),
    ("current", EQ15, np.full(300, 20e-6)),  # saturates the amplifier: anti-windup path
    ("voltage", B.Compensation(), 120 * np.sin(np.linspace(0, 4 * np.pi, 1000)) + 30),
]


@pytest.mark.parametrize("mode, compensation, drive", CASES)
def test_numba_kernel_equals_the_reference(mode, compensation, drive):
    kc = B.kernel_constants(PARAMS, FS, compensation)
    noise = PARAMS.instruments.meter_noise * np.random.default_rng(3).standard_normal(drive.size)
    s_fast, s_slow = B.initial_state(kc), B.initial_state(kc)
    fast = B.run(mode, drive, noise, kc, s_fast)
    slow = B.run_reference(mode, drive, noise, kc, s_slow)
    scale = np.max(np.abs(slow), axis=0)
    scale[scale == 0] = 1.0
    # each step's root (Newton here, Brent to 4ε there) differs by a few ε, and the states keep
    # them for longer than the run (creep, heat): they add up to n·4ε at most
    tol = float(rtol(1.0, roundings=4 * drive.size))
    assert np.max(np.abs(fast - slow) / scale) < tol
    np.testing.assert_allclose(s_fast, s_slow, rtol=tol, atol=1e-20)  # atol: states that sit at 0


def test_kernel_is_chunk_invariant():
    kc = B.kernel_constants(PARAMS, FS, EQ15)
    drive = np.r_[np.full(700, 300e-9), np.full(700, -300e-9)]
    noise = np.random.default_rng(1).standard_normal(drive.size) * 5e-12
    whole = B.run("current", drive, noise, kc, B.initial_state(kc))
    state = B.initial_state(kc)
    parts = [
        B.run("current", drive[i : i + 333], noise[i : i + 333], kc, state)
        for i in range(0, drive.size, 333)
    ]
    np.testing.assert_array_equal(np.vstack(parts), whole)


# ---------------------------------------------------------------------------------------------
# Captures, catalogue and dispatch
# ---------------------------------------------------------------------------------------------
def _capture(tmp_path, name, seed):
    return B.simulate_bender_capture(
        tmp_path / name,
        PARAMS,
        daq_plan(MANIFEST),
        current((3.0, 300e-9)),
        EQ15,
        {"dataset": "tokin_nb40"},
        seed,
        "det",
        chunk_len=128,
    ).path


def test_capture_carries_channels_settings_and_truth(tmp_path):
    path = _capture(tmp_path, "a.nc", 7)
    with open_capture(path, require=ronkanen.CHANNELS) as cap:
        assert cap.n == 300 and cap.fs == FS
        assert cap.attrs["drive_quantity"] == "current" and cap.attrs["compensation"] == "model_10"
        assert cap.attrs["compensation_R"] == 21e9
        params, states = cap.read_truth()
        data = cap.read(["i_cmd", "x_disp"])
    assert params["actuator_R"] == PARAMS.actuator.R and params["pid_ki"] == PARAMS.pid.ki
    assert set(B.TRUTH_STATES) <= set(states)
    assert np.allclose(data["i_cmd"], 300e-9, rtol=1e-3)
    assert data["x_disp"][-1] > 10e-6


def test_same_seed_same_capture(tmp_path):
    a, b, c = (_capture(tmp_path, f"{k}.nc", seed) for k, seed in (("a", 7), ("b", 7), ("c", 8)))
    with open_capture(a) as ca, open_capture(b) as cb, open_capture(c) as cc:
        da, db, dc = (x.read(["I", "x_disp"]) for x in (ca, cb, cc))
    for ch in ("I", "x_disp"):
        np.testing.assert_array_equal(da[ch], db[ch])
        assert not np.array_equal(da[ch], dc[ch])


def test_simulate_experiment_dispatches_model_bender(tmp_path):
    config = load_config(ROOT / "tests" / "config" / "smoke.yaml")
    path = simulate_experiment(
        ROOT / "raw", "tokin_nb40", "rk_ramp_300na_1g", config, tmp_path / "r.nc"
    ).path
    with open_capture(path) as cap:
        assert cap.attrs["compensation"] == "impedance" and cap.attrs["compensation_X"] == 1e9
        assert cap.attrs["dataset"] == "tokin_nb40" and cap.duration == pytest.approx(100.0)


def test_catalogue_compensations():
    catalogue = expand_protocols(["ronkanen"], "thesis")
    assert B.compensation_of(catalogue["rk_static_hold"]) == B.Compensation()
    assert B.compensation_of(catalogue["rk_ramp_300na_10g"]) == B.Compensation("impedance", X=10e9)
    assert B.compensation_of(catalogue["rk_drift_current"], IDENTIFIED) == B.Compensation(
        "model_10", **IDENTIFIED
    )
    repeat = drive_from_protocol(catalogue["rk_repeat_current"].protocol)
    assert repeat.duration == pytest.approx(20 * 240.0)


def test_the_eq15_runs_take_the_identified_R_and_c_never_the_twins():
    """The paper ran Eq 15 with the R and c it identified (Eq 12): every Eq 15 run of the
    catalogue takes them from the identification, and without them it does not run (no number
    stands in, least of all the twin's built R and c); the identification's own captures (the
    hold, the ramps) have fixed settings, so the identification never needs itself."""
    catalogue = expand_protocols(["ronkanen"], "thesis")
    eq15 = {n for n, e in catalogue.items() if e.compensation and "impedance" not in e.compensation}
    assert eq15 == {"rk_decay_current", "rk_repeat_current", "rk_drift_current"}
    assert all(B.needs_identification(catalogue[n].compensation) for n in eq15)
    identification = ["rk_static_hold", *(n for n in catalogue if n.startswith("rk_ramp_"))]
    assert not any(B.needs_identification(catalogue[n].compensation) for n in identification)
    with pytest.raises(ValueError, match=r"rk_drift_current: .*needs the identified R and c"):
        B.compensation_of(catalogue["rk_drift_current"])


def _protocol(compensation):
    return {
        "chapter": "x",
        "experiments": {
            "e": {
                "description": "d",
                "quantity": "current",
                "segments": [{"duration": 1.0}],
                "compensation": compensation,
            }
        },
    }


@pytest.mark.parametrize(
    "compensation",
    [
        {"impedance": 1e9, "R": 21e9, "c": 3.4e7},
        {"R": 21e9},
        {"X": 1e9},
        {"R": "identified", "c": 3.4e7},  # half identified: a built number would stand in
        {"R": "identified"},
        {"R": "fitted", "c": "fitted"},
        {"impedance": "identified"},
    ],
)
def test_protocol_schema_rejects_a_bad_compensation(compensation):
    with pytest.raises(ManifestError):
        validate_document(_protocol(compensation), "protocol.schema.yaml", "test.yaml")


@pytest.mark.parametrize(
    "compensation",
    [{"impedance": 2e9}, {"R": 21e9, "c": 3.4e7}, {"R": "identified", "c": "identified"}],
)
def test_protocol_schema_accepts_a_fixed_or_an_identified_compensation(compensation):
    validate_document(_protocol(compensation), "protocol.schema.yaml", "test.yaml")


def test_manifest_rejects_an_unknown_twin_section():
    with pytest.raises(ValueError, match="unknown key"):
        B.BenderParams.from_manifest(MANIFEST["twin"] | {"thermal": {}})


# ---------------------------------------------------------------------------------------------
# The analysis on the twin's records: parameter recovery and the paper's claims
# ---------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def identified():
    hold, _ = run_experiment("rk_static_hold")
    ramps = [
        run_experiment(n)[0]
        for n in ("rk_ramp_300na_10g", "rk_ramp_300na_1g", "rk_ramp_300na_2g", "rk_ramp_100na_6g")
    ]
    ramp_table, table_1, ident = ronkanen.identify(hold, ramps, 40.0, 2.0)
    value = ident.set_index("key")["value"]
    return ramp_table, table_1, ronkanen.table_2_both(table_1, value["R"]), value


def test_identification_recovers_R_a_and_c_of_the_twin(identified):
    _, table_1, table_2, value = identified
    act = PARAMS.actuator
    assert value["R"] == pytest.approx(act.R, rel=0.03)
    assert value["a"] == pytest.approx(act.a, rel=0.01)
    twin = table_2[table_2["source"] == "twin captures"].set_index("equation")
    assert twin["best"].idxmax() == "(10)"
    assert twin.loc["(10)", "c"] == pytest.approx(act.c, rel=0.05)
    for _, row in table_1.iterrows():
        i = row["charging current [nA]"] * 1e-9
        assert row["identified X [GOhm]"] * 1e9 == pytest.approx(
            act.R / np.hypot(act.c * i, 1), rel=0.03
        )


def test_table_2_from_the_paper_is_the_library_table(identified):
    table_2 = identified[2]
    paper = table_2[table_2["source"] == "paper Table 1"].reset_index(drop=True)
    np.testing.assert_allclose(paper["SSE [GOhm^2]"], pl.table_2()["SSE [GOhm^2]"])


def identified_files(identified, folder):
    """The identification of the fixture as rules powerloss_identify and powerloss_table_2 write
    it: (identified.csv, table_2.csv) in ``folder``."""
    _, _, table_2, value = identified
    paths = folder / "identified.csv", folder / "table_2.csv"
    value.rename_axis("key").reset_index().to_csv(paths[0], index=False)
    table_2.to_csv(paths[1], index=False)
    return paths


def test_the_eq15_setting_is_read_from_the_identification(identified, tmp_path):
    """R from the hold (identified.csv), c of model (10) fitted to the twin's ramps (table_2)."""
    _, _, table_2, value = identified
    eq15 = B.identified_compensation(*identified_files(identified, tmp_path))
    twin = table_2[table_2["source"] == "twin captures"].set_index("equation")
    assert eq15 == {"R": value["R"], "c": twin.loc["(10)", "c"]}


def test_an_eq15_capture_runs_with_the_identified_R_and_c_not_the_twins(identified, tmp_path):
    """The capture records the R and c its compensation ran with: the identification's, which
    differ from the twin's built ones; without them the run stops."""
    eq15 = B.identified_compensation(*identified_files(identified, tmp_path))
    config = load_config(ROOT / "tests" / "config" / "smoke.yaml")
    path = simulate_experiment(
        ROOT / "raw", "tokin_nb40", "rk_drift_current", config, tmp_path / "d.nc", identified=eq15
    ).path
    with open_capture(path) as cap:
        assert cap.attrs["compensation"] == "model_10"
        ran = {"R": float(cap.attrs["compensation_R"]), "c": float(cap.attrs["compensation_c"])}
    assert ran == eq15
    assert ran["R"] != PARAMS.actuator.R and ran["c"] != PARAMS.actuator.c
    with pytest.raises(ValueError, match="needs the identified R and c"):
        simulate_experiment(
            ROOT / "raw", "tokin_nb40", "rk_drift_current", config, tmp_path / "x.nc"
        )


def test_compensated_current_control_beats_open_loop_voltage_control(identified):
    """The paper's claims (Section 7–8): hysteresis and drift fall by an order of magnitude, with
    Eq 15 run on the R and c identified from the hold and the ramps."""
    _, _, table_2, value = identified
    twin = table_2[table_2["source"] == "twin captures"].set_index("equation")
    eq15 = {"R": value["R"], "c": twin.loc["(10)", "c"]}
    a_cmd = value["a_cmd"]
    pairs = {
        k: {c: run_experiment(f"rk_{k}_{c}", identified=eq15)[0] for c in ("current", "voltage")}
        for k in ("decay", "repeat", "drift")
    }
    table = ronkanen.performance(
        pairs["decay"], pairs["repeat"], pairs["drift"], a_cmd, 40.0, 120.0
    )
    value = table.set_index(["measure", "control"])["value"]
    for measure in ("hysteresis [%]", "drift over the hold [%]"):
        assert abs(value[measure, "current"]) < abs(value[measure, "voltage"]) / 5
    assert value["decaying-ramp max error [um]", "current"] < 20.0
    assert abs(value["repeatability drift [%]", "current"]) < 2.0
    assert len(ronkanen.cycles(pairs["repeat"]["current"], a_cmd)) == 20
