"""Rule `characterise`: every capture of a dataset streamed once → the characterisation table (stroke,
gains, loop width, nonlinearity, creep, and with the current dx/dq and the q–U loop), the
manifest's actuator and sensors, and the loop figure's pages.

Alone: python workflow/scripts/characterise.py raw/<dataset>/dataset.yaml table.csv instruments.csv \
    loops/ raw/<dataset>/*.nc
"""

import argparse
from pathlib import Path

import pandas as pd

from selfsense import characterise as ch
from selfsense.manifest import load_manifest
from selfsense.provenance import save_figure, script_logging, write_table


def main(manifest, captures, table, instruments_table, figures, settle_s=0.1, min_hold_s=1.0, log=None):
    logger = script_logging(log)
    rows, loops = [], []
    for k, capture in enumerate(captures, 1):
        row, panels = ch.characterise_capture(capture, settle_s, min_hold_s)
        rows.append(row)
        loops += [panels] if panels else []
        logger.info("%d/%d %s: %s", k, len(captures), capture, row)
    Path(figures).mkdir(parents=True, exist_ok=True)
    for k, fig in enumerate(ch.loop_pages(loops, Path(manifest).parent.name), 1):
        save_figure(fig, Path(figures) / f"loops_{k:02d}.png", inputs=captures)
    write_table(pd.DataFrame(rows, columns=ch.TABLE_COLUMNS), table, inputs=captures)
    write_table(pd.DataFrame(ch.instruments(load_manifest(manifest)), columns=["item", "property", "value"]),
                instruments_table, inputs=[manifest])


if "snakemake" in globals():
    i, o, p = snakemake.input, snakemake.output, snakemake.params
    main(i.manifest, list(i.capture), o.table, o.instruments, o.figures, p.settle_s, p.min_hold_s, snakemake.log[0])
elif __name__ == "__main__":
    cli = argparse.ArgumentParser(description=__doc__)
    for arg in ("manifest", "table", "instruments_table", "figures"):
        cli.add_argument(arg)
    cli.add_argument("captures", nargs="+")
    main(**vars(cli.parse_args()))
