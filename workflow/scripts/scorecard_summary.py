"""Rule `scorecard_summary`: the short reStructuredText that opens the report (emergent numbers per
chapter first), the counts per dataset, kind and chapter as a table (the README quotes it, via
scripts/update_docs.py), and two pages of the long lists (what is out of band and why; what is
still to come), from every dataset's scorecard. The lists are pages of their own, not part of the
opening: Snakemake's report centres its landing text vertically, so a long one would start above
the top of the window.

Project-wide: this run's datasets (``cards``) and every other dataset's scorecard an earlier run
left (``earlier``, read as they are); the text says which datasets it covers and, for the earlier
ones, when their scorecard was written.
"""

import time
from pathlib import Path

import pandas as pd

from selfsense.io.provenance import atomic_path, provenance, script_logging, write_json, write_table
from selfsense.scorecard.render import landing_rst, out_of_band_rst, pending_rst, rst_html, summary


def written(path):
    """When a file was written (its mtime), in UTC to the minute."""
    return time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime(Path(path).stat().st_mtime))


def coverage(this_run, earlier):
    """reStructuredText of one paragraph: the datasets covered, this run's and the earlier ones'
    (each with its scorecard's date). A name is a folder's (letters, digits, _ and -): a literal."""
    text = "Datasets: " + ", ".join(f"``{d}``" for d in this_run) + " (this run)"
    for dataset, when in earlier.items():
        text += f"; ``{dataset}`` (scorecard of an earlier run, {when})"
    return text + "."


def with_coverage(page, paragraph):
    """A list page's reStructuredText with the paragraph under its title (its first block)."""
    title, _, body = page.partition("\n\n")
    return f"{title}\n\n{paragraph}\n\n{body}"


def main(cards, summary_rst, counts, out_of_band, not_yet, campaign="thesis", log=None, earlier=()):
    logger = script_logging(log)
    # results/<dataset>/scorecard.csv: the folder names the dataset
    this_run = [Path(c).parent.name for c in cards]
    dates = {Path(c).parent.name: written(c) for c in earlier}
    inputs = [*cards, *earlier]
    read = {Path(c).parent.name: pd.read_csv(c) for c in inputs}
    paragraph = coverage(this_run, dates)
    text = f"{paragraph}\n\n{landing_rst(read)}"
    pages = {
        out_of_band: with_coverage(out_of_band_rst(read), paragraph),
        not_yet: with_coverage(pending_rst(read), paragraph),
    }
    covered = {"datasets": {"this run": this_run, "earlier runs": dates}}
    with atomic_path(summary_rst) as tmp:
        tmp.write_text(text, encoding="utf-8")
    write_json(provenance(inputs, **covered), f"{summary_rst}.json")
    write_table(summary(read), counts, inputs=inputs, config={"campaign": campaign}, **covered)
    for page, rst in pages.items():
        with atomic_path(page) as tmp:
            tmp.write_text(rst_html(rst), encoding="utf-8")
        write_json(provenance(inputs, **covered), f"{page}.json")
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
        list(snakemake.input.earlier),
    )
