"""Rule `audit_realtime`: recompute the HPO offline from a closed-loop capture and compare it with
the real-time estimate the loop logged (the published loop used what the pipeline analyses).

Alone: python workflow/scripts/audit_realtime.py raw/pi_p885/ch6_p2a_closed.nc gamma.json observer.json out.json
"""

import argparse

import numpy as np

from selfsense.capture import open_capture
from selfsense.gamma import load_gamma
from selfsense.observer import load_gains
from selfsense.provenance import provenance, script_logging, write_json
from selfsense.ripple import plan_from_capture
from selfsense.selfsensing import SelfSensingChain


def main(capture, gamma, observer, report, n_periods, log=None):
    logger = script_logging(log)
    worst = 0.0
    with open_capture(capture, require=("Ur", "Ir", "I", "x_hpo_rt")) as cap:
        chain = SelfSensingChain(plan_from_capture(cap, n_periods), load_gamma(gamma), load_gains(observer), cap.fs)
        for _, d in cap.iter_chunks(("Ur", "Ir", "I", "x_hpo_rt")):
            offline = chain.process(d["Ur"], d["Ir"], d["I"])["x_hat"]
            worst = max(worst, float(np.max(np.abs(offline - d["x_hpo_rt"]))))
        lsb = cap.resolution("x_hpo_rt")
    write_json({"capture": capture, "max |offline − logged| [nm]": worst * 1e9, "log resolution [nm]": lsb * 1e9,
                "provenance": provenance([capture, gamma, observer], {"n_periods": n_periods})}, report)
    logger.info("%s: offline vs logged HPO differ by at most %.3f nm", capture, worst * 1e9)


if "snakemake" in globals():
    i = snakemake.input
    main(i.capture, i.gamma, i.observer, snakemake.output.report, snakemake.params.n_periods, snakemake.log[0])
elif __name__ == "__main__":
    cli = argparse.ArgumentParser(description=__doc__)
    for name in ("capture", "gamma", "observer", "report"):
        cli.add_argument(name)
    cli.add_argument("--np", dest="n_periods", type=int, default=4)
    main(**vars(cli.parse_args()))
