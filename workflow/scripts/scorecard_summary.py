"""Rule `scorecard_summary`: the reStructuredText that opens the report (counts, what is out of
band and why, what is still to come), from every dataset's scorecard.

Alone: python workflow/scripts/scorecard_summary.py out.rst results/pi_p885/scorecard.csv ...
"""

import argparse
from pathlib import Path

import pandas as pd

from selfsense.provenance import atomic_path, provenance, script_logging, write_json
from selfsense.scorecard import summary_rst


def main(cards, summary, log=None):
    logger = script_logging(log)
    # results/<dataset>/scorecard.csv: the folder names the dataset
    text = summary_rst({Path(c).parent.name: pd.read_csv(c) for c in cards})
    with atomic_path(summary) as tmp:
        tmp.write_text(text, encoding="utf-8")
    write_json(provenance(cards), f"{summary}.json")
    logger.info("\n%s", text)


if "snakemake" in globals():
    main(list(snakemake.input.cards), snakemake.output.summary, snakemake.log[0])
elif __name__ == "__main__":
    cli = argparse.ArgumentParser(description=__doc__)
    cli.add_argument("summary")
    cli.add_argument("cards", nargs="+")
    main(**vars(cli.parse_args()))
