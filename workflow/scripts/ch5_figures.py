"""Rule `ch5_figures`: Figures 5.1, 5.2, 5.4–5.8, 5.10, 5.12–5.14."""

from pathlib import Path

from selfsense.chapters.ch5 import figures_ch5
from selfsense.io.capture import open_capture, read_series
from selfsense.io.provenance import run, save_figure, script_logging
from selfsense.methods.observer import load_gains


def main(
    series,
    series_f,
    gamma_capture,
    gamma_series,
    traces,
    traces_f,
    creep,
    observer,
    n_periods,
    orders,
    inputs,
    log,
    pdf,
    **out,
):
    """series / traces: paths; series_f / traces_f: {experiment: frequency [Hz]} of each; out:
    {figure name: path}."""
    logger = script_logging(log)
    with open_capture(gamma_capture) as cap:
        warmup = float(cap.attrs.get("warmup_s", 0.0))
    built = figures_ch5(
        {float(series_f[Path(p).stem]): read_series(p) for p in series},
        read_series(gamma_series),
        n_periods,
        orders,
        {float(traces_f[Path(p).stem]): read_series(p) for p in traces},
        read_series(creep),
        load_gains(observer),
        warmup,
    )
    for name, fig in built.items():
        save_figure(fig, out[name], inputs=inputs, pdf=pdf)
    logger.info("wrote %s", ", ".join(sorted(built)))


if "snakemake" in globals():
    run(main, snakemake)
