"""Rule `scorecard_summary`: the short reStructuredText that opens the report (emergent numbers per
chapter first), the counts per dataset, kind and chapter as a table (the README quotes it, via
scripts/update_docs.py), and two pages of the long lists (what is out of band and why; what is
still to come), from every dataset's scorecard. The lists are pages of their own, not part of the
opening: Snakemake's report centres its landing text vertically, so a long one would start above
the top of the window.
"""

from pathlib import Path

import pandas as pd

from selfsense.io.provenance import atomic_path, provenance, script_logging, write_json, write_table
from selfsense.scorecard.render import landing_rst, out_of_band_rst, pending_rst, rst_html, summary


def main(cards, summary_rst, counts, out_of_band, not_yet, campaign="thesis", log=None):
    logger = script_logging(log)
    # results/<dataset>/scorecard.csv: the folder names the dataset
    read = {Path(c).parent.name: pd.read_csv(c) for c in cards}
    text = landing_rst(read)
    pages = {out_of_band: out_of_band_rst(read), not_yet: pending_rst(read)}
    with atomic_path(summary_rst) as tmp:
        tmp.write_text(text, encoding="utf-8")
    write_json(provenance(cards), f"{summary_rst}.json")
    write_table(summary(read), counts, inputs=cards, config={"campaign": campaign})
    for page, rst in pages.items():
        with atomic_path(page) as tmp:
            tmp.write_text(rst_html(rst), encoding="utf-8")
        write_json(provenance(cards), f"{page}.json")
    logger.info("\n%s", "\n".join([text, *pages.values()]))


if "snakemake" in globals():
    main(
        list(snakemake.input.cards),
        snakemake.output.summary,
        snakemake.output.counts,
        snakemake.output.out_of_band,
        snakemake.output.not_yet,
        snakemake.params.campaign,
        snakemake.log[0],
    )
