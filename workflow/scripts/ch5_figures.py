"""Rule `ch5_figures`: Figures 5.1, 5.2, 5.4–5.8, 5.10, 5.12–5.14."""

from selfsense.chapters.ch5 import figures_ch5
from selfsense.io.capture import open_capture, read_series
from selfsense.io.provenance import save_figure, script_logging
from selfsense.methods.observer import load_gains


def main(
    series, gamma_capture, gamma_series, traces, creep, observer, out, n_periods, orders, log, pdf
):
    """series / traces: {frequency [Hz]: path}; out: {figure name: path}."""
    logger = script_logging(log)
    with open_capture(gamma_capture) as cap:
        warmup = float(cap.attrs.get("warmup_s", 0.0))
    built = figures_ch5(
        {float(f): read_series(p) for f, p in series.items()},
        read_series(gamma_series),
        n_periods,
        orders,
        {float(f): read_series(p) for f, p in traces.items()},
        read_series(creep),
        load_gains(observer),
        warmup,
    )
    inputs = [*series.values(), *traces.values(), creep, observer]
    for name, fig in built.items():
        save_figure(fig, out[name], inputs=inputs, pdf=pdf)
    logger.info("wrote %s", ", ".join(sorted(built)))


if "snakemake" in globals():
    i, p = snakemake.input, snakemake.params
    main(
        dict(zip(p.series_f, i.series)),
        i.gamma_capture,
        i.gamma_series,
        dict(zip(p.traces_f, i.traces)),
        i.creep,
        i.observer,
        dict(snakemake.output.items()),
        p.n_periods,
        p.orders,
        snakemake.log[0],
        pdf=p.pdf,
    )
