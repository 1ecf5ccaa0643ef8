"""Rule `observer_study`: observer max error against ω_S and an added offset current
(one capture).
"""

from selfsense.chapters import figures
from selfsense.chapters.ch5 import observer_study
from selfsense.io.capture import open_capture
from selfsense.io.provenance import run, save_figure, script_logging, write_table
from selfsense.methods.gamma import load_gamma
from selfsense.methods.observer import load_gains
from selfsense.methods.ripple import plan_from_capture

CHANNELS = ("Ur", "Ir", "I", "x_laser")


def main(capture, gamma, observer, table, figure, omegas, offsets, n_periods, inputs, log, pdf):
    logger = script_logging(log)
    a0 = load_gains(observer).a0
    with open_capture(capture, require=CHANNELS) as cap:
        plan = plan_from_capture(cap, n_periods)
        settle, fs = float(cap.attribute("warmup_s")), cap.fs

    def chunks():
        with open_capture(capture) as cap:
            yield from cap.iter_chunks(CHANNELS)

    result = observer_study(chunks, plan, load_gamma(gamma), a0, fs, settle, omegas, offsets)
    cfg = {"omegas": list(omegas), "offsets": list(offsets), "n_periods": n_periods}
    write_table(result, table, inputs=inputs, config=cfg)
    save_figure(figures.observer_study(result), figure, inputs=inputs, config=cfg, pdf=pdf)
    logger.info("\n%s", result.to_string())


if "snakemake" in globals():
    run(main, snakemake)
