"""Rule `observe`: the self-sensing chain (ripple → Γ → HPO) over one capture, offline
(selfsense.chapters.ch5.observe_capture)."""

from selfsense.chapters.ch5 import observe_capture
from selfsense.io.capture import SeriesWriter
from selfsense.io.provenance import provenance, run, script_logging, write_json
from selfsense.methods.gamma import load_gamma
from selfsense.methods.observer import load_gains

UNITS = {"time": "s", "x_laser": "m", "x_hat": "m", "x_cp": "m", "i0_hat": "A"}


def main(capture, gamma, observer, traces, stats, n_periods, transient_s, inputs, log=None):
    """transient_s: for the creep run, the max error is taken in its transient and
    steady state too."""
    logger = script_logging(log)
    poly, gains = load_gamma(gamma), load_gains(observer)
    result, trace = observe_capture(capture, poly, gains, n_periods, transient_s)
    config = {"n_periods": n_periods, "transient_s": transient_s}
    with SeriesWriter(traces, UNITS, {"capture": capture}, inputs=inputs, config=config) as out:
        out.write(trace)
    write_json(result | {"provenance": provenance(inputs, config)}, stats)
    logger.info("%s: %s", capture, result)


if "snakemake" in globals():
    run(main, snakemake)
