"""Rule `characterise_page`: the captures of one page of a dataset's loop figure, each streamed once
and measured on its steady full-amplitude drive cycles → their rows of the characterisation table
(stroke, gains, loop width, nonlinearity, the cycles used and dropped, creep, and with the current
dx/dq and the q–U loop, the own hysteresis model's errors on held-out cycles) and the models'
parameters as JSON, and their page of the loop figure (dropped cycles faint). ``periods``:
capture name → its drive's period [s] from the protocol (else found from U); ``scalings``:
channel → its declared scaling; ``cycle_rules``: CycleRules fields; ``hysteresis``: the model
fit's max_order and order_tolerance (None: the library's defaults).
"""

from pathlib import Path

from selfsense.chapters import characterise as ch
from selfsense.io.provenance import provenance, run, save_figure, script_logging, write_json
from selfsense.methods.cycles import CycleRules


def main(
    captures,
    rows,
    figure,
    title,
    settle_s,
    min_hold_s,
    periods,
    scalings,
    cycle_rules,
    hysteresis,
    inputs,
    pdf,
    log=None,
):
    logger = script_logging(log)
    rules, found, loops, model = CycleRules.from_mapping(cycle_rules), [], [], []
    for capture in captures:
        period = (periods or {}).get(Path(capture).stem)
        row, panels, parameters = ch.characterise_capture(
            capture, settle_s, min_hold_s, period, scalings or None, rules, hysteresis
        )
        found, model = found + [row], model + parameters
        loops += [panels] if panels else []
        logger.info("%s: %s", capture, row)
    save_figure(ch.loop_page(loops, title), figure, inputs=inputs, pdf=pdf)
    write_json({"rows": found, "model": model, "provenance": provenance(inputs)}, rows)


if "snakemake" in globals():
    run(main, snakemake)
