"""Rule `check_capture`: validate a capture and count NaN / clipped samples → qc/<experiment>.json.

Alone: python workflow/scripts/check_capture.py raw/pi_p885/ch3_sine_10hz.nc out.json
"""

import argparse

from selfsense.capture import scan_capture, write_scan_report
from selfsense.provenance import script_logging


def main(capture, report, log=None):
    logger = script_logging(log)
    scan = scan_capture(capture)
    write_scan_report(scan, report)
    logger.info("%s: %d samples, NaN %s, clipped %s", capture, scan.n_samples,
                sum(scan.nan.values()), sum(scan.clipped.values()))


if "snakemake" in globals():
    main(snakemake.input.capture, snakemake.output.report, snakemake.log[0])
elif __name__ == "__main__":
    cli = argparse.ArgumentParser(description=__doc__)
    cli.add_argument("capture")
    cli.add_argument("report")
    main(**vars(cli.parse_args()))
