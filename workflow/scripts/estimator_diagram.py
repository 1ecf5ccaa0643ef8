"""Rule `estimator_diagram`: Figure 7.9 — block diagrams of the coupled estimation as rule `coupled`
runs it, annotated with the identified τ, γ, k/α, Γ_T and observer gains.
"""

import json
from pathlib import Path

from selfsense.chapters import ch7
from selfsense.io.provenance import run, save_figure, script_logging
from selfsense.methods.electromech import load_k_over_alpha
from selfsense.methods.gamma import load_gamma
from selfsense.methods.observer import load_gains
from selfsense.methods.ripple import plan_from_fs


def main(gamma_t, observer, thermal_model, model, figure, fs, fr, ns, n_periods, inputs, log, pdf):
    logger = script_logging(log)
    fig, shown = ch7.figure_7_9(
        load_gamma(gamma_t),
        load_gains(observer),
        json.loads(Path(thermal_model).read_text()),
        load_k_over_alpha(model),
        plan_from_fs(fs, fr, ns, n_periods),
    )
    # the sidecar records the numbers the diagram shows, for audits that cannot read a PNG
    save_figure(fig, figure, inputs=inputs, config={"n_periods": n_periods}, shown=shown, pdf=pdf)
    logger.info("Figure 7.9 shows %s", shown)


if "snakemake" in globals():
    run(main, snakemake)
