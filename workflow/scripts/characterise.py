"""Rule `characterise`: one capture's stroke, gains, loop width, nonlinearity, creep (and with the
current dx/dq and the q–U loop) → a table row (JSON) and the loop figure.

Alone: python workflow/scripts/characterise.py raw/pi_p885/ch3_sine_10hz.nc row.json loop.png
"""

import argparse
from pathlib import Path

from selfsense import characterise as ch
from selfsense.capture import open_capture
from selfsense.figures import placeholder
from selfsense.provenance import provenance, save_figure, script_logging, write_json


def main(capture, row, figure, settle_s=0.1, min_hold_s=1.0, log=None):
    logger = script_logging(log)
    name = Path(capture).stem
    with open_capture(capture) as cap:
        x = ch.displacement_channel(cap.channels)
        if "U" not in cap.channels or x is None:
            note = "no drive voltage U and displacement in this capture"
            write_json(ch.row(name, {}, x, None, note) | {"provenance": provenance([capture])}, row)
            save_figure(placeholder(name, note), figure, inputs=[capture])
            logger.info("%s: %s", capture, note)
            return
        names = ["U", x] + (["I"] if "I" in cap.channels else [])
        factor = ch.reduction_factor(cap.n)
        reduced = ch.block_means(cap.iter_chunks(names, factor * (1 << 14)), cap.fs, factor)
    measures = ch.characterise(reduced, x, settle_s, min_hold_s)
    write_json(ch.row(name, measures, x, reduced.fs) | {"provenance": provenance([capture])}, row)
    save_figure(ch.loop_figure(reduced, x, name), figure, inputs=[capture])
    logger.info("%s: %s", capture, measures)


if "snakemake" in globals():
    main(snakemake.input.capture, snakemake.output.row, snakemake.output.figure, snakemake.params.settle_s,
         snakemake.params.min_hold_s, snakemake.log[0])
elif __name__ == "__main__":
    cli = argparse.ArgumentParser(description=__doc__)
    for arg in ("capture", "row", "figure"):
        cli.add_argument(arg)
    main(**vars(cli.parse_args()))
