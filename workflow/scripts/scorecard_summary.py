"""Rule `scorecard_summary`: the short reStructuredText that opens the report (counts per dataset)
and two pages of the long lists (what is out of band and why; what is still to come), from every
dataset's scorecard. The lists are pages of their own, not part of the opening: Snakemake's report
centres its landing text vertically, so a long one would start above the top of the window.

Alone: python workflow/scripts/scorecard_summary.py out.rst out_of_band.html not_yet.html results/pi_p885/scorecard.csv ...
"""

import argparse
from pathlib import Path

import pandas as pd

from selfsense.provenance import atomic_path, provenance, script_logging, write_json
from selfsense.scorecard import landing_rst, out_of_band_rst, pending_rst, rst_html


def main(cards, summary, out_of_band, not_yet, log=None):
    logger = script_logging(log)
    # results/<dataset>/scorecard.csv: the folder names the dataset
    read = {Path(c).parent.name: pd.read_csv(c) for c in cards}
    text = landing_rst(read)
    pages = {out_of_band: out_of_band_rst(read), not_yet: pending_rst(read)}
    with atomic_path(summary) as tmp:
        tmp.write_text(text, encoding="utf-8")
    write_json(provenance(cards), f"{summary}.json")
    for page, rst in pages.items():
        with atomic_path(page) as tmp:
            tmp.write_text(rst_html(rst), encoding="utf-8")
        write_json(provenance(cards), f"{page}.json")
    logger.info("\n%s", "\n".join([text, *pages.values()]))


if "snakemake" in globals():
    main(list(snakemake.input.cards), snakemake.output.summary, snakemake.output.out_of_band,
         snakemake.output.not_yet, snakemake.log[0])
elif __name__ == "__main__":
    cli = argparse.ArgumentParser(description=__doc__)
    for name in ("summary", "out_of_band", "not_yet"):
        cli.add_argument(name)
    cli.add_argument("cards", nargs="+")
    main(**vars(cli.parse_args()))
