"""How much of the closed loop's C_e-estimate error the drive's leak through the ripple high-pass makes.

Simulates one closed-loop experiment twice on the twin, as rule simulate_closed_loop does (the
same Γ, gains and k/α), once as the twin is and once with the drive's leak into the ripple channels
(instruments.HighPass.leak) set to zero, and prints for each the mean and spread of
Γ(Ĉ_e) − Γ(C_e) after the warm-up: the error budget's "C_e estimate" source before the observer's
filter (docs/methods.md, "The observer's error budget").

    .venv/bin/python scripts/drive_leak_check.py results/pi_p885 [--experiment ch6_p1_closed]
"""

import argparse
import contextlib
import sys
import tempfile
from pathlib import Path
from unittest import mock

import numpy as np

from selfsense.capture import open_capture
from selfsense.error_budget import CHANNELS, Truth
from selfsense.gamma import load_gamma
from selfsense.manifest import load_config
from selfsense.observer import load_gains
from selfsense.ripple import plan_from_capture
from selfsense.selfsensing import SelfSensingChain
from selfsense.twin.instruments import HighPass

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "workflow" / "scripts"))
import simulate_closed_loop  # noqa: E402  (the rule's own script, so the run is the campaign's)


def estimate_error(capture, gamma, gains, n_periods):
    """Γ(Ĉ_e) − Γ(C_e) [m] at every sample after the capture's warm-up."""
    with open_capture(capture, require=CHANNELS) as cap:
        truth = Truth.from_group(*cap.read_truth(), cap.length(), capture)
        chain = SelfSensingChain(plan_from_capture(cap, n_periods), gamma, gains, cap.fs)
        warmup, parts = float(cap.attribute("warmup_s")), []
        for start, t, _, out in chain.against_laser(cap.iter_chunks(CHANNELS)):
            exact = chain.gamma.predict(truth.at(start + np.arange(len(t)))["C_e"], chain.temperature)
            parts.append((out["x_cp"] - exact)[t >= warmup])
    return np.concatenate(parts)


def _without_leak(self, *args, _init=HighPass.__init__):
    """HighPass with a zero numerator in its drive path: the ripple channels see no drive."""
    _init(self, *args)
    self.b = np.zeros_like(self.b)


def main(results, experiment, config="config.yaml", raw="raw"):
    c, out = load_config(config), Path(tempfile.mkdtemp())
    gamma, gains = load_gamma(f"{results}/ch5/gamma.json"), load_gains(f"{results}/ch5/observer.json")
    no_leak = mock.patch.object(HighPass, "__init__", _without_leak)
    for name, patch in (("as the twin is", contextlib.nullcontext()), ("drive leak set to zero", no_leak)):
        capture = out / f"{experiment}.nc"
        with patch:
            simulate_closed_loop.main(raw, Path(results).name, experiment, f"{results}/ch5/gamma.json",
                                      f"{results}/ch5/observer.json", f"{results}/ch4/model.json", c["campaign"],
                                      c["capture"], c["control"]["omega_c"], c["ripple"]["n_periods"],
                                      output=capture, report=out / f"{experiment}.json")
        e = estimate_error(capture, gamma, gains, c["ripple"]["n_periods"]) * 1e6
        print(f"{experiment}, {name}: Γ(Ĉ_e) − Γ(C_e) mean {e.mean():+.3f} µm, std {e.std():.3f} µm")


if __name__ == "__main__":
    cli = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    cli.add_argument("results", help="results/<dataset> of a campaign (its Γ, gains and k/α)")
    cli.add_argument("--experiment", default="ch6_p1_closed")
    cli.add_argument("--config", default="config.yaml")
    main(**vars(cli.parse_args()))
