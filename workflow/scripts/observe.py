"""Rule `observe`: the self-sensing chain (ripple → Γ → HPO) over one capture, offline."""

from selfsense.chapters.ch5 import creep_phases, run_observer
from selfsense.io.capture import SeriesWriter, open_capture
from selfsense.io.provenance import provenance, script_logging, write_json
from selfsense.methods.gamma import load_gamma
from selfsense.methods.observer import load_gains
from selfsense.methods.ripple import plan_from_capture

UNITS = {"time": "s", "x_laser": "m", "x_hat": "m", "x_cp": "m", "i0_hat": "A"}


def main(capture, gamma, observer, traces, stats, n_periods, transient_s=None, log=None):
    """transient_s: for the creep run, the max error is taken in its transient and
    steady state too."""
    logger = script_logging(log)
    poly, gains = load_gamma(gamma), load_gains(observer)
    with open_capture(capture, require=("Ur", "Ir", "I", "x_laser")) as cap:
        plan = plan_from_capture(cap, n_periods)
        settle = float(cap.attribute("warmup_s"))
        phases = creep_phases(settle, transient_s) if transient_s is not None else ()
        result, trace = run_observer(
            cap.iter_chunks(("Ur", "Ir", "I", "x_laser")),
            plan,
            poly,
            gains,
            cap.fs,
            settle,
            phases=phases,
        )
        nan = dict(cap.stats.nan)
    with SeriesWriter(traces, UNITS, {"capture": capture}) as out:
        out.write(trace)
    write_json(
        result
        | {
            "warmup [s]": settle,
            "NaN samples": nan,
            "provenance": provenance(
                [capture, gamma, observer], {"n_periods": n_periods, "transient_s": transient_s}
            ),
        },
        stats,
    )
    logger.info("%s: %s", capture, result)


if "snakemake" in globals():
    i, o = snakemake.input, snakemake.output
    p = snakemake.params
    main(
        i.capture,
        i.gamma,
        i.observer,
        o.traces,
        o.stats,
        p.n_periods,
        p.transient_s,
        snakemake.log[0],
    )
