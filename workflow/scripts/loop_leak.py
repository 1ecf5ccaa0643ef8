"""Rule `loop_leak`: each closed-loop P2 run as simulated and again with the drive kept out of the
ripple channels — the drive at the folded ripple frequency, C_e's error and ε_OCL (twin study).
"""

import pandas as pd

from selfsense.io.provenance import run, script_logging, write_table
from selfsense.methods.control import IntegralController
from selfsense.methods.electromech import load_k_over_alpha
from selfsense.methods.gamma import load_gamma
from selfsense.methods.observer import load_gains
from selfsense.twin.closed_loop import controller_factory
from selfsense.verify.loop_leak import leak_study


def main(
    captures,
    gamma,
    observer,
    model,
    table,
    campaign,
    capture_settings,
    omega_c,
    n_periods,
    inputs,
    log,
):
    logger = script_logging(log)
    g, gains = load_gamma(gamma), load_gains(observer)
    controller_for = controller_factory(
        n_periods, g, gains, IntegralController(omega_c, load_k_over_alpha(model))
    )
    rows = leak_study(
        captures,
        {"campaign": campaign, "capture": capture_settings},
        controller_for,
        n_periods,
        g,
        gains,
        omega_c,
    )
    write_table(pd.DataFrame(rows), table, inputs=inputs)
    logger.info("\n%s", pd.DataFrame(rows).set_index("run").T.to_string())


if "snakemake" in globals():
    run(main, snakemake)
