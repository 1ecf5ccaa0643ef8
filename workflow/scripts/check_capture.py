"""Rule `check_capture`: a capture against its manifest (fs, channels, units, attributes), then
validated (each channel one series along its time axis, packing within bounds, at least
MIN_SAMPLES samples on a time axis that advances by 1/fs) and streamed once to count missing
samples (FILL, each channel's _FillValue and missing_value: "nan") apart from clipped ones
→ qc/<experiment>.json. What an analysis needs beyond that it checks where it opens the capture.
In the workflow the capture is held to the parts of the manifest the checks read (the rule's
param, capture_contract in common.smk), which its report records: a new batch of experiments in
the manifest leaves an earlier capture's report as it was, and up to date.
"""

import json

from selfsense.io.capture import read_header, scan_capture, write_scan_report
from selfsense.io.contract import check_agreement, check_attributes, check_clipping
from selfsense.io.manifest import load_manifest
from selfsense.io.provenance import run, script_logging


def main(capture, manifest, report, log=None, contract=None):
    """``contract``: the parts of the manifest to hold the capture to (JSON); None, all of it."""
    logger = script_logging(log)
    header = read_header(capture)
    meta = json.loads(contract) if contract is not None else load_manifest(manifest)
    check_agreement(capture, header, meta, manifest)
    scan = scan_capture(capture)
    check_attributes(capture, header, meta, manifest)
    check_clipping(capture, scan.clipped, header, manifest)
    if contract is None:
        write_scan_report(scan, report, inputs=[capture, manifest])
    else:
        checked = {"manifest": str(manifest), "checked against": meta}
        write_scan_report(scan, report, inputs=[capture], config=checked)
    logger.info(
        "%s: %d samples, missing (NaN) %s, clipped %s",
        capture,
        scan.n_samples,
        sum(scan.nan.values()),
        sum(scan.clipped.values()),
    )


if "snakemake" in globals():
    run(main, snakemake)
