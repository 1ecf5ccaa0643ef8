"""Rule `powerloss_truth`: Ronkanen's Section 7 results from the sensor and from the twin's true
displacement, and the sensor's share (twin validation: reads /truth).
"""

from selfsense.chapters import ronkanen
from selfsense.io.provenance import script_logging, write_table
from selfsense.verify.powerloss_truth import performance_truth, true_displacement


def main(captures, identified, table, drift_start, drift_duration=120.0, log=None):
    """captures: {"<decay|repeat|drift>_<current|voltage>": path}."""
    logger = script_logging(log)
    records = ronkanen.read_records(captures.values())
    true_x = {
        rec.name: true_displacement(path) for rec, path in zip(records.values(), captures.values())
    }
    result = performance_truth(
        ronkanen.by_kind(records, captures),
        true_x,
        ronkanen.load_identified(identified, "a_cmd"),
        drift_start,
        drift_duration,
    )
    write_table(
        result,
        table,
        inputs=[*captures.values(), identified],
        config={"drift_start": drift_start, "drift_duration": drift_duration},
    )
    logger.info("\n%s", result.to_string())


if "snakemake" in globals():
    i, p = snakemake.input, snakemake.params
    main(
        {k: i[k] for k in ronkanen.PAIRS},
        i.identified,
        snakemake.output[0],
        p.drift_start,
        p.drift_duration,
        snakemake.log[0],
    )
