"""Rule `simulate`: one experiment on the digital twin → raw/<dataset>/<experiment>.nc.

Alone: python workflow/scripts/simulate.py pi_p885 ch3_sine_10hz --config tests/config/smoke.yaml
"""

import argparse

from selfsense.manifest import load_config
from selfsense.provenance import script_logging
from selfsense.twin import simulate_experiment


def main(dataset, experiment, config, output=None, log=None):
    logger = script_logging(log)
    path = simulate_experiment(config["raw_dir"], dataset, experiment, config, output)
    logger.info("wrote %s (campaign %s)", path, config["campaign"])


if "snakemake" in globals():
    main(snakemake.wildcards.dataset, snakemake.wildcards.experiment, snakemake.config,
         snakemake.output.capture, snakemake.log[0])
elif __name__ == "__main__":
    cli = argparse.ArgumentParser(description=__doc__)
    cli.add_argument("dataset")
    cli.add_argument("experiment")
    cli.add_argument("--config", default="config.yaml")
    args = cli.parse_args()
    main(args.dataset, args.experiment, load_config(args.config))
