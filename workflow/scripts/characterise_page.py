"""Rule `characterise_page`: up to six captures of a dataset, each streamed once → their rows of the
characterisation table (stroke, gains, loop width, nonlinearity, creep, and with the current dx/dq
and the q–U loop) as JSON, and their page of the dataset's loop figure.
"""

from selfsense.io.provenance import provenance, save_figure, script_logging, write_json
from selfsense.methods import characterise as ch


def main(captures, rows_json, figure, title, settle_s=0.1, min_hold_s=1.0, log=None):
    logger = script_logging(log)
    rows, loops = [], []
    for capture in captures:
        row, panels = ch.characterise_capture(capture, settle_s, min_hold_s)
        rows.append(row)
        loops += [panels] if panels else []
        logger.info("%s: %s", capture, row)
    save_figure(ch.loop_page(loops, title), figure, inputs=captures)
    write_json({"rows": rows, "provenance": provenance(captures)}, rows_json)


if "snakemake" in globals():
    i, o, p = snakemake.input, snakemake.output, snakemake.params
    main(list(i.capture), o.rows, o.figure, p.title, p.settle_s, p.min_hold_s, snakemake.log[0])
