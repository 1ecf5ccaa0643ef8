"""Rule `identify`: Case 1 and Case 2 for every set → Tables 4.1–4.3, per-set table, model.json."""

import json
from pathlib import Path

from selfsense.chapters import ch4
from selfsense.io.capture import read_series
from selfsense.io.manifest import load_manifest
from selfsense.io.provenance import provenance, run, script_logging, write_json, write_table
from selfsense.methods.electromech import geometry_from_actuator, model_record


def main(series, static, manifest, inputs, log=None, **out):
    """series: list of ripple-series paths (one per set); out: {name: output path}."""
    logger = script_logging(log)
    meta = load_manifest(manifest)
    actuator = meta["actuator"]
    geometry = geometry_from_actuator(actuator, f"{manifest}: actuator")
    k_static = ch4.load_static_stiffness(static)
    sets = {Path(p).stem: read_series(p) for p in series}
    per_set, fits = ch4.identify_sets(sets, k_static, float(actuator["moving_mass_kg"]), geometry)
    write_table(per_set, out["sets"], inputs=inputs)
    write_table(ch4.table_4_1(), out["table_4_1"])
    write_table(ch4.table_4_2(per_set), out["table_4_2"], inputs=inputs)
    write_table(ch4.table_4_3(fits, geometry), out["table_4_3"], inputs=inputs)
    write_table(ch4.hysteresis_voltage(sets, fits)[0], out["hysteresis_voltage"], inputs=inputs)
    model = model_record(per_set[per_set["case"] == 2])
    write_json(model | {"provenance": provenance(inputs)}, out["model"])
    logger.info("Case 2 means: %s", json.dumps(model))


if "snakemake" in globals():
    run(main, snakemake)
