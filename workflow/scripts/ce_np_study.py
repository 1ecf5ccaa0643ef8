"""Rule `ce_np_study`: C_e error against np and ripple-frequency wander, on the twin."""

from selfsense.chapters import figures
from selfsense.io.manifest import load_manifest
from selfsense.io.provenance import run, save_figure, script_logging, write_table
from selfsense.twin.experiment import daq_plan
from selfsense.twin.params import TwinParams
from selfsense.verify.studies import ce_error_vs_np_and_wander


def main(manifest, table, figure, nps, wanders, drive_hz, inputs, log, pdf):
    logger = script_logging(log)
    meta = load_manifest(manifest)
    result = ce_error_vs_np_and_wander(
        TwinParams.from_manifest(meta["twin"]),
        daq_plan(meta),
        list(nps),
        list(wanders),
        drive_hz=drive_hz,
        seed=meta.get("seed", 0),
    )
    config = {"np": list(nps), "wander_hz": list(wanders), "drive_hz": drive_hz}
    recorded = {"inputs": inputs, "config": config, "seed": meta.get("seed", 0)}
    write_table(result, table, **recorded)
    save_figure(figures.np_study(result), figure, pdf=pdf, **recorded)
    logger.info("\n%s", result.to_string())


if "snakemake" in globals():
    run(main, snakemake)
