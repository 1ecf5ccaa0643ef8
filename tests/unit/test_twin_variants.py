"""The twin's variants (docs/twin.md, "Variants"): each term against its closed form, its numba
stage against its numpy reference, and its off value giving today's twin bit for bit (the
shipped captures themselves: tests/unit/test_capture_bits.py)."""

import dataclasses

import numpy as np
import pytest

from selfsense.twin import kernel as K
from selfsense.twin.bench import Bench, experiment_seed
from selfsense.twin.params import LoadPathParams, TwinParams
from selfsense.twin.variants import series_load

FS = 48000.0
SENSOR = 1.05e9  # the static test's force sensor, 1.05 kN/µm (ch4_static_blocked)


def quiet(params: TwinParams) -> TwinParams:
    """``params`` with a stack whose static solution is the linear one: no hysteresis, creep or
    ΔC (U_P = U, q linear in U_P and x), no instrument noise."""
    return dataclasses.replace(
        params,
        stack=dataclasses.replace(params.stack, dC_x=0.0, kappa_T=0.0),
        hysteresis=dataclasses.replace(params.hysteresis, v_total=1e-12, R_visc=0.0),
        creep=dataclasses.replace(params.creep, C=(1e6,), tau=(1.0,)),
        instruments=dataclasses.replace(params.instruments, F_noise=0.0, U_noise=0.0),
    )


# --- the load path's series compliance ------------------------------------------------------------


def test_series_load_is_the_springs_in_series_and_off_the_same_float():
    assert series_load(SENSOR, 0.05e-6) == pytest.approx(1 / (1 / SENSOR + 0.05e-6), rel=1e-15)
    assert series_load(SENSOR, 0.0) is SENSOR
    assert series_load(0.0, 0.05e-6) == 0.0  # a free stroke has no load to be compliant with


@pytest.mark.parametrize("compliance", [0.0, 2e-8, 5e-8])
def test_the_static_test_sees_the_stack_in_series_with_the_load_path(
    stack_params, stack_daq, compliance
):
    """Eq 4.16's k = F_blocked/x_free on the twin with a compliance c in the load path is the
    stack's k in series with the sensor and c: 1/(1/k + 1/k_sensor + c) (the preload spring's
    share of k, k_spring, also pushes on the sensor: (k_spring + k_L)·k/(k + k_L) exactly)."""
    params = quiet(stack_params)
    params = dataclasses.replace(params, load_path=LoadPathParams(compliance))
    n = int(0.2 * FS)
    t = np.arange(n) / FS
    U = 100.0 * np.minimum(t / 0.05, 1.0)  # a 50 ms ramp to 100 V, then held
    hold = t > 0.15  # the bench mode (2500 Hz, ζ = 0.05) has settled long before
    free = Bench(params, stack_daq, experiment_seed(1, "free"))
    _, truth = free.step(t, U)
    blocked = Bench(params, stack_daq, experiment_seed(1, "blocked"), SENSOR)
    measured, _ = blocked.step(t, U)
    k_static = (np.mean(measured["F"][hold]) - measured["F"][0]) / np.mean(truth["x"][hold])
    s = params.stack
    k_load = 1 / (1 / SENSOR + compliance)
    # 1e-4: the force channel's ADC step (0.06 N) and the settled ripple on ≈ 900 N
    assert k_static == pytest.approx((s.k_spring + k_load) * s.k / (s.k + k_load), rel=1e-4)
    # the closed form Table 4.2's k is read against leaves out the factor 1 + k_spring/k_L
    apparent = 1 / (1 / s.k + 1 / SENSOR + compliance)
    assert k_static == pytest.approx(apparent, rel=s.k_spring / k_load + 1e-4)


def test_the_load_path_off_is_todays_bench_and_leaves_truth_as_it_was(stack_params, stack_daq):
    on = dataclasses.replace(stack_params, load_path=LoadPathParams(0.0))
    assert on == stack_params
    assert "load_path_compliance" not in stack_params.truth_attrs()
    assert dataclasses.replace(on, load_path=LoadPathParams(1e-8)).truth_attrs()[
        "load_path_compliance"
    ] == pytest.approx(1e-8)
    bench = Bench(on, stack_daq, experiment_seed(1, "x"), SENSOR)
    assert bench.load_stiffness == SENSOR
    np.testing.assert_array_equal(
        bench.kc.scalars, K.kernel_constants(stack_params, stack_daq.fs, SENSOR).scalars
    )


def test_a_manifest_switches_the_load_path_on(stack_manifest):
    twin = dict(stack_manifest["twin"]) | {"load_path": {"compliance": 3e-8}}
    assert TwinParams.from_manifest(twin).load_path.compliance == 3e-8
    with pytest.raises(ValueError, match="twin.load_path: unknown key"):
        TwinParams.from_manifest(dict(twin) | {"load_path": {"stiffness": 1.0}})
