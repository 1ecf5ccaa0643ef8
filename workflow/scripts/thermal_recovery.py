"""Rule `thermal_recovery`: Table 7.1's τ, γ, k_T and Γ_T's g against the twin's truth
(simulated datasets).
"""

import pandas as pd

from selfsense.chapters import ch7
from selfsense.io.capture import open_capture
from selfsense.io.provenance import run, script_logging, write_table
from selfsense.methods.gamma import load_gamma


def main(table_7_1, gamma_t, truth_capture, recovery, inputs, log=None):
    logger = script_logging(log)
    with open_capture(truth_capture) as cap:
        truth, _ = cap.read_truth()
    result = ch7.thermal_recovery(pd.read_csv(table_7_1), truth, load_gamma(gamma_t).g)
    write_table(result, recovery, inputs=inputs)
    logger.info("\n%s", result.to_string())


if "snakemake" in globals():
    run(main, snakemake)
