"""Rule `gamma_t_fit`: Γ_T with temperature (Eq 7.13) on the 50 Hz heating run — Tables 7.2, 7.3
(at the thesis's n = 5) and Γ_T of the order validated on the hotter 100 Hz run
(selfsense.chapters.ch7.gamma_t_fits).
"""

from selfsense.chapters.ch7 import figure_7_7, gamma_t_fits, while_driven
from selfsense.io.capture import read_series
from selfsense.io.provenance import (
    provenance,
    run,
    save_figure,
    script_logging,
    write_json,
    write_table,
)


def main(
    samples,
    power,
    val_samples,
    val_power,
    figure,
    orders,
    gamma_t_order,
    candidates,
    spans,
    inputs,
    log,
    pdf,
    **out,
):
    logger = script_logging(log)
    s, p, vs, vp = (read_series(f) for f in (samples, power, val_samples, val_power))
    spans = tuple(tuple(span) for span in spans)
    tables, records = gamma_t_fits(s, p, vs, vp, spans, orders, gamma_t_order, candidates)
    cfg = {"orders": list(orders), "order": gamma_t_order, "candidates": list(candidates)}
    cfg |= {"spans": [list(span) for span in spans]}
    for name, table in tables.items():
        write_table(table, out[name], inputs=inputs, config=cfg)
    for name, record in records.items():
        write_json(record | {"provenance": provenance(inputs, cfg)}, out[name])
    save_figure(figure_7_7(while_driven(s, spans[0])), figure, inputs=inputs, pdf=pdf)
    logger.info("\n%s\n%s", tables["table_7_2"].to_string(), tables["order"].to_string())


if "snakemake" in globals():
    run(main, snakemake)
