"""Rule `gamma_fit`: Γ (Eq 5.4) on the 0.1 Hz data — Table 5.1, Table 5.2 at the chosen order
and at the thesis's j = 5, both Γ.
"""

from selfsense.chapters.ch5 import gamma_data, gamma_tables
from selfsense.io.capture import open_capture, read_series
from selfsense.io.provenance import provenance, run, script_logging, write_json, write_table


def main(capture, series, n_periods, orders, inputs, log=None, **out):
    logger = script_logging(log)
    with open_capture(capture) as cap:
        warmup = float(cap.attrs.get("warmup_s", 0.0))
    C, x = gamma_data(read_series(series), n_periods, warmup)
    tables, gammas = gamma_tables(C, x, orders)
    cfg = {"n_periods": n_periods, "orders": list(orders), "warmup_s": warmup}
    for name, table in tables.items():
        write_table(table, out[name], inputs=inputs, config=cfg)
    for name, gamma in gammas.items():
        write_json(gamma.record() | {"provenance": provenance(inputs, cfg)}, out[name])
    logger.info("chosen order %d\n%s", gammas["gamma"].order, tables["table_5_1"].to_string())


if "snakemake" in globals():
    run(main, snakemake)
