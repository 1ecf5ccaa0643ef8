"""Rule `characterise_page`: the captures of one page of a dataset's loop figure, each streamed once
and measured on its steady full-amplitude drive cycles → their rows of the characterisation table
(stroke, gains, loop width, nonlinearity, the cycles used and dropped, creep, and with the current
dx/dq and the q–U loop, the own hysteresis model's errors on held-out cycles) and the models'
parameters as JSON, and their page of the loop figure (dropped cycles faint). Optional params:
``periods`` (capture name → its drive's period [s] from the protocol, else found from U),
``scalings`` (channel → its declared scaling), ``cycle_rules`` (CycleRules fields),
``hysteresis`` (the model fit's max_order and order_tolerance).
"""

from pathlib import Path

from selfsense.io.provenance import provenance, save_figure, script_logging, write_json
from selfsense.methods import characterise as ch
from selfsense.methods.cycles import CycleRules


def main(
    captures, rows_json, figure, title, settle_s=0.1, min_hold_s=1.0, log=None, pdf=True, **options
):
    logger = script_logging(log)
    rules, rows, loops, model = CycleRules.from_mapping(options.get("cycle_rules")), [], [], []
    periods, scalings = options.get("periods") or {}, options.get("scalings") or None
    for capture in captures:
        period = periods.get(Path(capture).stem)
        row, panels, parameters = ch.characterise_capture(
            capture, settle_s, min_hold_s, period, scalings, rules, options.get("hysteresis")
        )
        rows, model = rows + [row], model + parameters
        loops += [panels] if panels else []
        logger.info("%s: %s", capture, row)
    save_figure(ch.loop_page(loops, title), figure, inputs=captures, pdf=pdf)
    write_json({"rows": rows, "model": model, "provenance": provenance(captures)}, rows_json)


if "snakemake" in globals():
    i, o, p = snakemake.input, snakemake.output, snakemake.params
    options = {k: p.get(k) for k in ("periods", "scalings", "cycle_rules", "hysteresis")}
    args = (o.rows, o.figure, p.title, p.settle_s, p.min_hold_s, snakemake.log[0])
    main(list(i.capture), *args, pdf=p.pdf, **options)
