"""Each stage artefact's loader reads back what its writer wrote."""

import numpy as np
import pandas as pd
import pytest

from selfsense.chapters import ronkanen
from selfsense.io.capture import CaptureWriter, channel_spec, open_capture
from selfsense.io.provenance import provenance, write_json, write_table
from selfsense.methods.electromech import MODEL_KEYS, load_k_over_alpha, model_record
from selfsense.methods.gamma import GammaPolynomial, fit_gamma, load_gamma
from selfsense.methods.observer import HPOGains, load_gains
from selfsense.methods.ripple import SamplingPlan, plan_from_capture


@pytest.mark.parametrize("with_t", [False, True])
def test_gamma_round_trip(tmp_path, with_t):
    rng = np.random.default_rng(0)
    C = rng.uniform(2.1e-6, 3.2e-6, 200)
    T = rng.uniform(20.0, 40.0, 200)
    x = 1e-6 * (30.0 - 10.0 * (C * 1e6 - 2.1) ** 2 + (0.2 * T if with_t else 0.0))
    poly = GammaPolynomial.from_fit(fit_gamma(C, x, 4, temperature=T if with_t else None))
    write_json(poly.record() | {"provenance": provenance([])}, tmp_path / "gamma.json")
    back = load_gamma(tmp_path / "gamma.json")
    assert back == poly and back.order == 4
    np.testing.assert_array_equal(back.predict(C, T), poly.predict(C, T))


def test_gains_round_trip(tmp_path):
    gains = HPOGains(16.6, 2 * np.pi, 0.8)
    write_json(gains.record() | {"provenance": provenance([])}, tmp_path / "observer.json")
    assert load_gains(tmp_path / "observer.json") == gains


def test_k_over_alpha_round_trip(tmp_path):
    case2 = pd.DataFrame(
        {key: [1.0 + i, 2.0 + i] for i, key in enumerate(MODEL_KEYS)}
        | {"frequency [Hz]": [10, 100]}
    )
    record = model_record(case2)
    assert record["b"] == case2["b"].iloc[1]  # damping from the fast sets only, where b·ẋ shows
    write_json(record | {"provenance": provenance([])}, tmp_path / "model.json")
    assert load_k_over_alpha(tmp_path / "model.json") == record["k"] / record["alpha"] == 3.5 / 4.5


@pytest.mark.parametrize("nf", [4, 5])
def test_plan_from_capture_is_the_plan_the_capture_was_sampled_with(tmp_path, nf):
    plan = SamplingPlan(1e5, 12, nf, 1)
    attrs = {"fs": plan.fs, "fr_nominal": plan.fr, "ns": plan.ns, "nf": plan.nf}
    with CaptureWriter(tmp_path / "c.nc", attrs, [channel_spec("U", -1.0, 1.0)], 24) as w:
        w.write({"U": np.zeros(24)})
    with open_capture(tmp_path / "c.nc") as cap:
        assert plan_from_capture(cap, 4) == SamplingPlan(1e5, 12, nf, 4)


def test_identified_constants_round_trip(tmp_path):
    identified = pd.DataFrame(
        [{"key": "R", "value": 2e9, "unit": "Ohm"}, {"key": "a_cmd", "value": 16.7, "unit": "m/C"}]
    )
    write_table(identified, tmp_path / "identified.csv")
    assert ronkanen.load_identified(tmp_path / "identified.csv", "a_cmd") == 16.7
    assert ronkanen.load_identified(tmp_path / "identified.csv", "R") == 2e9
