"""Rule `scorecard_summary`: the short reStructuredText that opens the report (emergent numbers per
chapter first), the counts per dataset, kind and chapter as a table (the README quotes it, via
scripts/update_docs.py), and two pages of the long lists (what is out of band and why; what is
still to come), from every dataset's scorecard. The lists are pages of their own, not part of the
opening: Snakemake's report centres its landing text vertically, so a long one would start above
the top of the window.

Project-wide: this run's datasets (``cards``) and every other dataset's scorecard an earlier run
left (``earlier``, as they are, each with its date).
"""

from pathlib import Path

import pandas as pd

from selfsense.io.provenance import (
    atomic_path,
    modified_utc,
    provenance,
    run,
    script_logging,
    write_json,
    write_table,
)
from selfsense.scorecard import render


def main(cards, earlier, summary, counts, out_of_band, not_yet, campaign, inputs, log=None):
    logger = script_logging(log)
    # results/<dataset>/scorecard.csv: the folder names the dataset
    this_run = [Path(c).parent.name for c in cards]
    dates = {Path(c).parent.name: modified_utc(c) for c in earlier}
    read = {Path(c).parent.name: pd.read_csv(c) for c in [*cards, *earlier]}
    text, out_of_band_rst, not_yet_rst = render.summary_pages(read, this_run, dates)
    covered = {"datasets": {"this run": this_run, "earlier runs": dates}}
    with atomic_path(summary) as tmp:
        tmp.write_text(text, encoding="utf-8")
    write_json(provenance(inputs, **covered), f"{summary}.json")
    config = {"campaign": campaign}
    write_table(render.summary(read), counts, inputs=inputs, config=config, **covered)
    for page, rst in ((out_of_band, out_of_band_rst), (not_yet, not_yet_rst)):
        with atomic_path(page) as tmp:
            tmp.write_text(render.rst_html(rst), encoding="utf-8")
        write_json(provenance(inputs, **covered), f"{page}.json")
    logger.info("\n%s", "\n".join([text, out_of_band_rst, not_yet_rst]))


if "snakemake" in globals():
    run(main, snakemake)
