"""The digital twin: calibration against the thesis's observations, kernel vs reference,
determinism.

These test the twin (its physics and parameters), not the analysis: each band is the thesis's
observation with the tolerance of its calibration band (docs/twin.md).
"""

import dataclasses

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from selfsense.io.capture import SLOW_CHANNELS, channel_spec, open_capture
from selfsense.methods.drive import Drive, Segment
from selfsense.methods.ripple import SamplingPlan, extract_impedance
from selfsense.scorecard.calibration import load_targets
from selfsense.twin import kernel as K
from selfsense.twin.bench import Bench, experiment_seed, simulate_capture
from selfsense.twin.instruments import HighPass, SlowProcess
from selfsense.twin.params import VARIANTS

from ..helpers import ROOT
from ..tolerances import rtol

FS = 48000.0


def raised_sine(f, duration, fs=FS, hi=100.0):
    """t [s] and a raised sine from 0 to hi at f [Hz]."""
    t = np.arange(int(round(duration * fs))) / fs
    return t, hi * 0.5 * (1 - np.cos(2 * np.pi * f * t))


def run(params, U, load_stiffness=0.0):
    kc = K.kernel_constants(params, FS, load_stiffness)
    state = K.initial_state(kc, params.thermal.T_amb)
    out = K.run(U, np.zeros_like(U), np.full_like(U, params.thermal.T_amb), kc, state)
    return dict(zip(K.OUTPUTS, out.T))


def test_stroke_at_100V_0p1Hz(stack_params):
    _, U = raised_sine(0.1, 10.0)
    x = run(stack_params, U)["x"]
    assert 30e-6 <= x.max() - x.min() <= 36e-6


def test_clamped_capacitance_falls_from_3p1_to_2p2_uF(stack_params):
    _, U = raised_sine(0.1, 10.0)
    C = run(stack_params, U)["C_P"]
    assert C[0] == pytest.approx(3.13e-6, rel=0.02)
    assert 2.0e-6 <= C.min() <= 2.4e-6


def test_piezo_voltage_at_the_top_of_a_100V_stroke(stack_params):
    """The true U_P against Table 4.3's 86 V in the band the twin is calibrated to (its identified
    U_Pmax, workflow/twin_calibration.yaml)."""
    _, U = raised_sine(0.1, 10.0)
    assert calibrated("up_top").within(run(stack_params, U)["U_P"].max())


def test_open_loop_feedforward_error_at_10Hz(stack_params):
    t, U = raised_sine(10.0, 1.0, hi=30e-6)
    x_ref = U
    out = run(stack_params, x_ref * stack_params.stack.k / stack_params.stack.alpha)
    steady = t >= 0.5
    error = np.max(np.abs(out["x"][steady] - x_ref[steady])) / 30e-6
    assert 0.09 <= error <= 0.17


def test_creep_over_175s_at_100V(stack_params):
    drive = Drive("voltage", (Segment(0.01, 50.0, 0.0, 100.0), Segment(175.0, 0.0, 0.0, 100.0)))
    t = np.arange(int(175.01 * FS)) / FS
    x = run(stack_params, drive(t))["x"]
    creep = x[-1] - x[int(0.02 * FS)]
    assert 0.3e-6 <= creep <= 1.5e-6


def test_ripple_current_leads_voltage_by_60_to_70_degrees(stack_params, stack_daq):
    bench = Bench(stack_params, stack_daq, experiment_seed(1, "phase"))
    t, U = raised_sine(10.0, 0.2)
    measured, _ = bench.step(t, U)
    blocks = extract_impedance(measured["Ur"], measured["Ir"], SamplingPlan(1e5, 12, 4, 4))
    phase = np.degrees(np.angle((blocks.B_I - 1j * blocks.A_I) / (blocks.B_V - 1j * blocks.A_V)))
    assert 60.0 <= np.median(phase) <= 70.0


def test_the_laser_records_position_rounded_to_its_resolution(stack_params, stack_daq):
    """Table 2.1's 0.3 µm resolution: with its drift off, the laser's error against the true x is
    within half a resolution step (plus half an ADC step of the packed channel) and, over a 1 Hz
    stroke crossing ≈ 100 steps, spreads as the rectangular r/√12, not as a noise of its own."""
    ins = stack_params.instruments
    params = dataclasses.replace(
        stack_params, instruments=dataclasses.replace(ins, laser_drift=0.0)
    )
    bench = Bench(params, stack_daq, experiment_seed(1, "laser"))
    t, U = raised_sine(1.0, 1.0)
    measured, truth = bench.step(t, U)
    error = measured["x_laser"] - truth["x"]
    adc_half_step = 0.5 * bench.adc["x_laser"].scale_factor
    assert np.max(np.abs(error)) <= ins.laser_resolution / 2 + adc_half_step
    assert np.std(error) == pytest.approx(ins.laser_resolution / np.sqrt(12), rel=0.05)


def calibrated(target_id):
    """The band the twin is calibrated to for one signature (workflow/twin_calibration.yaml)."""
    return next(
        t
        for t in load_targets(ROOT / "workflow" / "twin_calibration.yaml").targets
        if t.id == target_id
    )


def test_self_heating_at_100V_100Hz_comes_from_hysteresis_loss(stack_params):
    t, U = raised_sine(100.0, 600.0)
    out = run(stack_params, U)
    rise = out["T"] - stack_params.thermal.T_amb
    every = int(FS)  # one point per second
    tt, dT = t[::every], rise[::every]
    from scipy.optimize import curve_fit

    (steady, tau), _ = curve_fit(lambda s, a, tau: a * (1 - np.exp(-s / tau)), tt, dT, p0=(40, 100))
    assert calibrated("steady_temperature").within(stack_params.thermal.T_amb + steady)
    # the model's τ = ρcv/(k_T A), lengthened a little as C_P (and with it the loss) grows with T
    assert stack_params.thermal.tau <= tau <= 1.1 * stack_params.thermal.tau
    # the heat is the hysteresis loss ∮U_H dq: zero hysteresis, no heating
    cold = dataclasses.replace(
        stack_params,
        hysteresis=dataclasses.replace(stack_params.hysteresis, v_total=1e-9),
        creep=dataclasses.replace(stack_params.creep, C=(1e3,), tau=(1.0,)),
    )
    t2, U2 = raised_sine(100.0, 5.0)
    assert run(cold, U2)["T"].max() - stack_params.thermal.T_amb < 0.01


def viscous(params, R_visc):
    return dataclasses.replace(
        params, hysteresis=dataclasses.replace(params.hysteresis, R_visc=R_visc)
    )


def test_the_viscous_drop_dissipates_its_analytic_loss_growing_with_frequency(stack_params):
    """Alone in series (no Maxwell loop, no creep), the Voigt element τU̇_c + U_c = R I dissipates
    R∮I²dt/(1 + ω²τ²) per cycle of a sinusoidal current at ω, so at a given charge swing its loss
    per cycle grows ∝ f: the loop widens with the rate, where the rate-independent loop does not."""
    R = 5.0
    alone = dataclasses.replace(
        stack_params,
        hysteresis=dataclasses.replace(stack_params.hysteresis, R_visc=R, v_total=1e-9),
        creep=dataclasses.replace(stack_params.creep, C=(1e3,), tau=(1.0,)),
    )
    per_cycle = {}
    for f in (10.0, 100.0):
        t, U = raised_sine(f, 6 / f)
        out = run(alone, U)
        last = t >= 4 / f  # two steady cycles
        loss = np.sum(out["U_H"][last] * out["I"][last]) / FS / 2
        omega_tau = 2 * np.pi * f * alone.hysteresis.tau_visc
        assert loss == pytest.approx(
            R * np.sum(out["I"][last] ** 2) / FS / 2 / (1 + omega_tau**2), rel=0.01
        )
        per_cycle[f] = loss * (1 + omega_tau**2)
    assert per_cycle[100.0] == pytest.approx(10 * per_cycle[10.0], rel=0.01)


@pytest.mark.parametrize("R_visc", [0.0, 5.0])
def test_numba_kernel_equals_the_reference(stack_params, R_visc):
    _, U = raised_sine(10.0, 0.1)
    U = U + 3.0 * np.sin(2 * np.pi * 700 * np.arange(len(U)) / FS)  # excite the bench mode too
    stack_params = viscous(stack_params, R_visc)
    kc = K.kernel_constants(stack_params, FS)
    F = np.zeros_like(U)
    T = np.full_like(U, 23.0)
    s1, s2 = K.initial_state(kc, 23.0), K.initial_state(kc, 23.0)
    fast = K.run(U, F, T, kc, s1)
    slow = K.run_reference(U, F, T, kc, s2)
    # each step's root (Newton here, Brent to 4ε there) differs by a few ε, and the states keep
    # them for longer than the run (creep, heat): they add up to n·4ε at most
    tol = float(rtol(1.0, roundings=4 * len(U)))
    scale = np.max(np.abs(slow), axis=0)
    assert np.max(np.abs(fast - slow) / scale) < tol
    np.testing.assert_allclose(s1, s2, rtol=tol, atol=1e-15)  # atol: states that sit at 0


def test_kernel_is_chunk_invariant(stack_params):
    _, U = raised_sine(10.0, 0.05)
    kc = K.kernel_constants(stack_params, FS)
    whole = K.run(U, 0 * U, 0 * U + 23, kc, K.initial_state(kc, 23.0))
    state = K.initial_state(kc, 23.0)
    parts = [
        K.run(U[i : i + 333], 0 * U[i : i + 333], 0 * U[i : i + 333] + 23, kc, state)
        for i in range(0, len(U), 333)
    ]
    np.testing.assert_array_equal(np.vstack(parts), whole)


def _capture(tmp_path, name, params, daq, seed, chunk_len=4096):
    drive = Drive("voltage", (Segment(0.1, 10.0, 0.0, 100.0),))
    return simulate_capture(
        tmp_path / name, params, daq, drive, {}, seed, "det", chunk_len=chunk_len
    ).path


def test_same_seed_gives_identical_capture_data(tmp_path, stack_params, stack_daq):
    a = _capture(tmp_path, "a.nc", stack_params, stack_daq, 7)
    b = _capture(tmp_path, "b.nc", stack_params, stack_daq, 7)
    c = _capture(tmp_path, "c.nc", stack_params, stack_daq, 8)
    chans = list(stack_daq.channels[:6])
    with open_capture(a) as ca, open_capture(b) as cb, open_capture(c) as cc:
        da, db, dc = ca.read(chans), cb.read(chans), cc.read(chans)
    for ch in chans:
        np.testing.assert_array_equal(da[ch], db[ch])
        assert not np.array_equal(da[ch], dc[ch]), ch


def test_capture_carries_truth_and_contract_attributes(tmp_path, stack_params, stack_daq):
    path = _capture(tmp_path, "a.nc", stack_params, stack_daq, 7)
    with open_capture(path, require=stack_daq.channels) as cap:
        assert cap.attrs["ns"] == 12 and cap.attrs["nf"] == 4 and cap.attrs["source"] == "simulated"
        params, states = cap.read_truth()
        assert params["stack_k"] == stack_params.stack.k
        assert len(states["x"]) == -(-cap.n // 12)
        assert cap.n_slow == 1  # 0.1 s at 10 Hz


#: the signal chain's values the twin's nominal holds (the ideal amplifier, a probe as flat at the
#: ripple as at DC, a 16-bit ADC, a Butterworth high-pass) and values of their declared ranges
SIGNAL_CHAIN = st.fixed_dictionaries(
    {
        "amplifier_gain_at_folded_ripple": st.sampled_from([1.0, 0.3, 0.75]),
        "I_probe_gain_at_ripple": st.floats(0.97, 1.03),
        "adc_bits": st.integers(12, 16),
        "highpass_q": st.floats(0.5, 0.9),
    }
)


def with_signal_chain(params, chain):
    """``params`` with the signal chain's values ``chain`` (the high-pass's Q is the ripple's; the
    values ``chain`` leaves out stay as they are)."""
    chain = dict(chain)
    q = chain.pop("highpass_q", params.ripple.highpass_q)
    ripple = dataclasses.replace(params.ripple, highpass_q=q)
    # a twin variant's section ({"power_amplifier": {...}}) replaces the params' own
    variants = {
        name: type(getattr(params, name))(**chain.pop(name)) for name in VARIANTS if name in chain
    }
    instruments = dataclasses.replace(params.instruments, **chain)
    return dataclasses.replace(params, ripple=ripple, instruments=instruments, **variants)


@settings(max_examples=20, deadline=None)
@given(
    n=st.integers(1, 3000),
    every=st.integers(1, 30),
    first=st.integers(0, 29),
    seed=st.integers(0, 2**32 - 1),
    chain=SIGNAL_CHAIN,
)
def test_compiled_instruments_follow_the_numpy_reference(
    stack_params, stack_daq, n, every, first, seed, chain
):
    """record.record_block against Bench._instruments, over two chunks (the high-pass states carry),
    for signal chains across their declared ranges.

    Both do the same IEEE operations in the same order; a rounding-level difference (another
    complex-division algorithm) could move a value across one ADC boundary, so the measured
    channels agree to one ADC step and the truth to the rounding of a few dozen operations."""
    first = first % every
    params = with_signal_chain(stack_params, chain)
    benches = [Bench(params, stack_daq, experiment_seed(seed, "ref")) for _ in range(2)]
    for chunk in range(2):
        t = (chunk * n + np.arange(n)) / FS
        U = 50 - 50 * np.cos(2 * np.pi * 230 * t) + 20 * (t > 0.01)  # a step: the high-pass leaks
        (fast, fast_truth), (ref, ref_truth) = (
            b.step(t, U, truth_every=every, truth_first=first, compiled=compiled)
            for b, compiled in zip(benches, (True, False))
        )
        for c, values in ref.items():
            step = benches[1].adc[c].step if c in benches[1].adc else 0.0
            np.testing.assert_allclose(fast[c], values, rtol=0, atol=step, err_msg=c)
        for k, values in ref_truth.items():
            np.testing.assert_allclose(
                fast_truth[k], values, rtol=rtol(1.0, roundings=40), atol=0, err_msg=k
            )
    np.testing.assert_array_equal(benches[0].hp_i.zi, benches[1].hp_i.zi)


@settings(max_examples=20, deadline=None)
@given(
    lengths=st.lists(st.integers(1, 70000), min_size=1, max_size=3),
    seed=st.integers(0, 2**32 - 1),
    chain=SIGNAL_CHAIN,
    start=st.integers(0, 10**9),
)
def test_compiled_time_signals_are_numpys_bit_for_bit(
    stack_params, stack_daq, lengths, seed, chain, start
):
    """The ripple's carrier and the high-pass's response by their numba loops against their numpy
    expressions, over chunks in turn (the phase carries) from anywhere in a long run: equal, not
    close, since the twin's captures are made with the loops and must stay those numpy made."""
    params = with_signal_chain(stack_params, chain)
    benches = [Bench(params, stack_daq, experiment_seed(seed, "signals")) for _ in range(2)]
    for n in lengths:
        t = (start + np.arange(n)) / FS
        start += n
        fast, ref = (b.time_signals(t, compiled) for b, compiled in zip(benches, (True, False)))
        for k, values in ref.items():
            np.testing.assert_array_equal(fast[k], values, err_msg=k)
        assert benches[0].ripple.phase == benches[1].ripple.phase


@given(
    f=st.lists(st.floats(0.0, 1e7), min_size=1, max_size=50),
    cutoff=st.floats(1.0, 1e6),
    q=st.floats(0.1, 5.0),
)
def test_compiled_high_pass_response_is_numpys_bit_for_bit(f, cutoff, q):
    hp = HighPass(cutoff, FS, q)
    f = np.array(f)
    np.testing.assert_array_equal(hp.response(f), hp.response(f, compiled=False))


def test_truth_and_thermometers_keep_their_samples_whatever_the_truth_decimation(
    tmp_path, stack_params, stack_daq
):
    """The states are recorded on a grid that holds the truth's and the 10 Hz thermometers'
    samples: with a decimation that does not divide the thermometers' period (7 against 4800),
    the thermometers and the channels are those of the usual 12, and each truth is the kernel's
    state at its own samples. Chunks of 1000 samples start off both grids."""
    drive = Drive("voltage", (Segment(0.25, 10.0, 0.0, 100.0),))
    runs = {}
    for dec in (12, 7):
        path = simulate_capture(
            tmp_path / f"{dec}.nc",
            stack_params,
            stack_daq,
            drive,
            {},
            5,
            "grid",
            chunk_len=1000,
            truth_decimation=dec,
        ).path
        with open_capture(path) as cap:
            runs[dec] = (
                cap.read(list(stack_daq.channels[:6])),
                cap.read(["T_mid"], dim="time_slow"),
                cap.read_truth()[1],
            )
            n = cap.n
    U = drive(np.arange(n) / FS)
    x = run(stack_params, U)["x"]
    for dec, (_, _, truth) in runs.items():
        np.testing.assert_allclose(truth["x"], x[::dec].astype(np.float32), rtol=0, atol=0)
    for part in (0, 1):
        for c, values in runs[12][part].items():
            np.testing.assert_array_equal(runs[7][part][c], values, err_msg=c)
    assert len(runs[12][1]["T_mid"]) == 3  # 0.25 s at 10 Hz


class Hold:
    """A trivial real-time controller: holds a voltage, logs what it saw."""

    block_len = 12
    logs = ("x_ref", "x_hpo_rt", "u_cmd")
    engage_at = 0.01

    def __init__(self):
        self.seen = 0

    def command(self, t):
        return np.full(len(t), 40.0)

    def observe(self, t, measured):
        self.seen += len(t)
        return {
            "x_ref": np.zeros(len(t)),
            "x_hpo_rt": measured["x_laser"],
            "u_cmd": np.full(len(t), 40.0),
        }


def test_controller_hook_drives_the_bench_and_logs(tmp_path, stack_params, stack_daq):
    ctl = Hold()
    drive = Drive("position", (Segment(0.05, 0.0, 0.0, 0.0),))
    path = simulate_capture(
        tmp_path / "cl.nc",
        stack_params,
        stack_daq,
        drive,
        {},
        1,
        "cl",
        controller=ctl,
        chunk_len=1000,
    ).path
    with open_capture(path, require=["x_hpo_rt", "u_cmd"]) as cap:
        d = cap.read(["U", "u_cmd", "x_hpo_rt", "x_laser"])
    assert ctl.seen == cap.n
    engaged = np.arange(cap.n) / cap.fs >= ctl.engage_at
    assert np.median(d["U"][engaged]) == pytest.approx(40.0, abs=0.05)
    assert np.median(d["U"][~engaged]) == pytest.approx(0.0, abs=0.05)
    np.testing.assert_allclose(d["x_hpo_rt"], d["x_laser"], atol=1e-8)


@settings(max_examples=30, deadline=None)
@given(
    bandwidth=st.floats(1e-3, 100.0),
    t0=st.floats(0.0, 5000.0),
    split=st.integers(1, 9999),
    seed=st.integers(0, 2**32 - 1),
)
def test_slow_process_interpolation_is_exact_to_1e4_of_peak_and_chunk_invariant(
    bandwidth, t0, split, seed
):
    process = SlowProcess(np.random.default_rng(seed), peak=1.0, bandwidth=bandwidth)
    t = t0 + np.arange(10000) / 48000.0
    whole = process(t)
    assert np.max(np.abs(whole - process.exact(t))) < 1.3e-4
    # to rounding: numpy's vectorised sin may differ in the last bit with the array's length
    np.testing.assert_allclose(
        np.concatenate([process(t[:split]), process(t[split:])]), whole, rtol=0, atol=1e-12
    )


@settings(max_examples=40, deadline=None)
@given(
    durations=st.lists(st.floats(0.0, 0.01), min_size=1, max_size=8),
    levels=st.lists(st.floats(-50.0, 150.0), min_size=8, max_size=8),
    block=st.integers(1, 40),
)
def test_drive_in_short_blocks_equals_the_whole_span(durations, levels, block):
    """The closed loop evaluates the drive 12 samples at a time, touching only nearby segments."""
    drive = Drive(
        "voltage",
        tuple(Segment(d, 100.0 * (k % 2), 0.0, levels[k]) for k, d in enumerate(durations)),
    )
    t = np.arange(int(drive.duration * 48000) + 30) / 48000.0
    blocks = np.concatenate([drive(t[s : s + block]) for s in range(0, len(t), block)])
    np.testing.assert_array_equal(blocks, drive(t))


@pytest.mark.parametrize(
    "chain",
    [
        {},
        {
            "amplifier_gain_at_folded_ripple": 0.3,
            "I_probe_gain_at_ripple": 0.97,
            "adc_bits": 12,
            "highpass_q": 0.5,
        },
        {
            "power_amplifier": {"time_constant": 1.6e-4, "slew_time": 6.6e-6},
            "loop": {"delay_samples": 2},
        },
        {"support": {"compliance": 1e-6, "mass": 1.0, "zeta": 0.05}},
    ],
    ids=["nominal", "signal chain at its ranges' ends", "the variants on", "the support mode on"],
)
def test_compiled_closed_loop_follows_the_python_reference(
    tmp_path, stack_params, stack_daq, chain
):
    """The numba loop (twin.realtime) against the per-block Python chain and controller it replaces,
    from a warm-up (loop open, the observer learning) through engaged chunks that start mid-period,
    with the nominal signal chain and one at its declared ranges' ends.

    A rounding-level difference can move an ADC value across one rounding boundary: the measured
    channels agree to one ADC step. The logged estimate agrees to the rounding of the window sums
    (n_periods·ns terms) amplified by C_e's cancellation (Eq 3.12), κ computed from the windows."""
    from selfsense.methods.control import IntegralController
    from selfsense.methods.gamma import GammaPolynomial
    from selfsense.methods.observer import HPOGains
    from selfsense.methods.ripple import plan_from_capture
    from selfsense.twin.closed_loop import realtime_controller

    params = with_signal_chain(stack_params, chain)
    s = stack_params.stack
    gamma = GammaPolynomial((-1e6 * s.C_P0 / s.dC_x, 1.0 / s.dC_x))  # C_P0 + dC_x·x, inverted
    drive = Drive("position", (Segment(0.05), Segment(0.3, 10.0, 0.0, 15e-6)))
    runs = {}
    for compiled in (False, True):
        loop = realtime_controller(
            stack_daq,
            drive,
            0.05,
            4,
            gamma,
            HPOGains(17.0),
            IntegralController(2 * np.pi * 250, s.k / s.alpha),
            compiled=compiled,
        )
        path = simulate_capture(
            tmp_path / f"{compiled}.nc",
            params,
            stack_daq,
            drive,
            {},
            3,
            "closed",
            controller=loop,
            chunk_len=1000,
        ).path  # 1000: chunks start mid-period
        with open_capture(path) as cap:
            runs[compiled] = cap.read([*stack_daq.channels, "x_ref", "x_hpo_rt", "u_cmd"])
            bits = params.instruments.adc_bits
            steps = {
                c: cap.resolution(c)
                if c in SLOW_CHANNELS
                else channel_spec(c, *stack_daq.ranges[c], bits=bits).step
                for c in stack_daq.channels
            }
            plan = plan_from_capture(cap, 4)
    ref, fast = runs[False], runs[True]
    for c, step in steps.items():
        np.testing.assert_allclose(fast[c], ref[c], rtol=0, atol=step, err_msg=c)
    windows = extract_impedance(ref["Ur"], ref["Ir"], plan)
    kappa = np.max(
        (np.abs(windows.A_I * windows.B_V) + np.abs(windows.A_V * windows.B_I))
        / np.abs(windows.A_I * windows.B_V - windows.A_V * windows.B_I)
    )
    bound = rtol(kappa, roundings=plan.block_len)
    for c in ("x_ref", "x_hpo_rt", "u_cmd"):
        np.testing.assert_allclose(
            fast[c], ref[c], rtol=0, atol=bound * np.max(np.abs(ref[c])), err_msg=c
        )
    assert np.ptp(ref["x_hpo_rt"]) > 10e-6  # the loop tracked the 15 µm profile


def test_a_capture_blosc_cannot_store_is_written_again_with_zlib(tmp_path, monkeypatch):
    """HDF5's blosc filter fails on a chunk it cannot shrink (the thesis's ch5_sweep has one): the
    twin, being deterministic, writes the capture again with zlib level 1."""
    import netCDF4

    import selfsense.twin.experiment as twin
    from selfsense.io.capture import UnshrinkableChunk, compression_of
    from selfsense.io.manifest import load_config

    tried, simulate = [], twin.simulate_capture

    def refusing_blosc(path, *args, compression, **kwargs):
        tried.append(compression)
        if compression.startswith("blosc"):
            raise UnshrinkableChunk(f"{path}: HDF5 could not store a chunk")
        return simulate(path, *args, compression=compression, **kwargs)

    monkeypatch.setattr(twin, "simulate_capture", refusing_blosc)
    config = load_config(ROOT / "tests" / "config" / "smoke.yaml")
    scan = twin.simulate_experiment(
        ROOT / "raw", "pi_p885", "ch3_sine_10hz", config, tmp_path / "c.nc"
    )
    assert tried == ["blosc_zstd", "zlib"]
    with netCDF4.Dataset(scan.path) as nc:
        assert compression_of(nc["U"]) == "zlib"
    assert scan.n_samples > 0 and list(tmp_path.iterdir()) == [tmp_path / "c.nc"]


def test_a_run_simulated_after_others_in_one_process_equals_it_simulated_alone(tmp_path):
    """Rule simulate_ch4 simulates a protocol's runs one after another in one process: a run's
    capture must not depend on what ran before it (each draws from its own seed)."""
    import netCDF4

    import selfsense.twin.experiment as twin
    from selfsense.io.manifest import load_config

    config = load_config(ROOT / "tests" / "config" / "smoke.yaml")
    raw, run = ROOT / "raw", "ch4_sine_20hz_s1"
    alone = twin.simulate_experiment(raw, "pi_p885", run, config, tmp_path / "alone.nc")
    twin.simulate_experiment(raw, "pi_p885", "ch4_sine_10hz_s1", config, tmp_path / "before.nc")
    after = twin.simulate_experiment(raw, "pi_p885", run, config, tmp_path / "after.nc")
    with netCDF4.Dataset(alone.path) as a, netCDF4.Dataset(after.path) as b:
        for group_a, group_b in ((a, b), (a["truth"], b["truth"])):
            for name, variable in group_a.variables.items():
                assert np.array_equal(variable[:], group_b[name][:]), name
