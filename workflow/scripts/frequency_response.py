"""Rule `frequency_response`: Fig 5.3, x/q (Eq 5.2) from the stepped-sine sweep
against the model.
"""

import json
from pathlib import Path

from selfsense.chapters import ch5
from selfsense.io.capture import open_capture
from selfsense.io.provenance import run, save_figure, script_logging, write_table
from selfsense.methods import frequency_response as fr
from selfsense.methods.drive import drive_from_protocol


def main(capture, model, protocol, settle_s, inputs, log, pdf, **out):
    """protocol: the sweep's catalogue entry (segments, warmup); out: {table, peaks, figure}."""
    logger = script_logging(log)
    params = json.loads(Path(model).read_text())
    with open_capture(capture, require=fr.CHANNELS) as cap:
        measured = fr.measure_sweep(cap, drive_from_protocol(protocol).segments, settle_s)
    G = fr.transfer_function(params, measured.operating_position)
    table, peaks = fr.response_table(measured, G), fr.resonance_table(measured, G, params["m"])
    cfg = {
        "settle_s": settle_s,
        "operating position [µm]": measured.operating_position * 1e6,
        "model": {k: params[k] for k in ("C_P0", "dC_x", "alpha", "k", "m", "b")},
    }
    write_table(table, out["table"], inputs=inputs, config=cfg)
    write_table(peaks, out["peaks"], inputs=inputs, config=cfg)
    save_figure(ch5.figure_5_3(table, peaks, G), out["figure"], inputs=inputs, config=cfg, pdf=pdf)
    logger.info(
        "operating position %.2f µm\n%s\n%s",
        measured.operating_position * 1e6,
        table.to_string(),
        peaks.to_string(),
    )


if "snakemake" in globals():
    run(main, snakemake)
