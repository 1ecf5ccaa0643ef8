"""Rule `powerloss_truth`: Ronkanen's Section 7 results from the sensor and from the twin's true
displacement, and the sensor's share (twin validation: reads /truth).
"""

from pathlib import Path

from selfsense.chapters import ronkanen
from selfsense.io.provenance import run, script_logging, write_table
from selfsense.verify.powerloss_truth import performance_truth, true_displacement


def main(captures, pairs, identified, table, drift_start, drift_duration, inputs, log=None):
    """pairs: {"<decay|repeat|drift>_<current|voltage>": experiment} of the captures."""
    logger = script_logging(log)
    capture_of = {Path(c).stem: c for c in captures}
    paths = {pair: capture_of[e] for pair, e in pairs.items()}
    records = ronkanen.read_records(paths.values())
    true_x = {Path(p).stem: true_displacement(p) for p in paths.values()}
    result = performance_truth(
        ronkanen.by_kind(records, paths),
        true_x,
        ronkanen.load_identified(identified, "a_cmd"),
        drift_start,
        drift_duration,
    )
    write_table(
        result,
        table,
        inputs=inputs,
        config={"drift_start": drift_start, "drift_duration": drift_duration},
    )
    logger.info("\n%s", result.to_string())


if "snakemake" in globals():
    run(main, snakemake)
