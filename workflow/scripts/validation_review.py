"""Rule `validation_review`: the validation's verdicts beside the nominal scorecard and the prior
envelopes as committed (selfsense.envelope.review.review_table), and the forest of both
intervals (selfsense.envelope.figures.review_forest)."""

import pandas as pd

from selfsense.envelope import figures
from selfsense.envelope.review import review_table
from selfsense.io.provenance import run, script_logging, write_table


def main(verdicts, nominal, envelopes, title, pdf, inputs, log, review, forest):
    """nominal: the dataset's scorecard ([] when none is committed); envelopes: its envelopes'
    scorecards; review, forest: the outputs."""
    logger = script_logging(log)
    card = pd.read_csv(nominal[0]) if nominal else None
    table = review_table(pd.read_csv(verdicts), card, [pd.read_csv(p) for p in envelopes])
    write_table(table, review, inputs=inputs)
    fig = figures.review_forest(table, title)
    figures.validation_figure(fig, forest, inputs=inputs, pdf=pdf)
    logger.info("%d rows: %s", len(table), table["posterior"].value_counts().to_dict())


if "snakemake" in globals():
    run(main, snakemake)
