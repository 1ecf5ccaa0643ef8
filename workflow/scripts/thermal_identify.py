"""Rule `thermal_identify`: τ, γ, k_T from the heating runs (Table 7.1); Figures 7.1–7.3, 7.5–7.6.

Alone: run through Snakemake (`snakemake results/pi_p885/ch7/table_7_1.csv`).
"""

import json
from pathlib import Path

import pandas as pd

from selfsense import figures
from selfsense.capture import read_series
from selfsense.chapters import ch7
from selfsense.manifest import load_dataset
from selfsense.provenance import provenance, save_figure, script_logging, write_json, write_table
from selfsense.thermal import ThermalModel, ThermalProperties, predict_temperature


def _identified(identified, freq_series, volt_series, check_series, k_over_alpha, volt_segments, out, inputs):
    """Table 7.1, the model, trends and predictions, and their figures, from the identified runs."""
    write_table(ch7.table_7_1(identified, k_over_alpha, 23.0), out["table_7_1"], inputs=inputs)
    model_fit = ThermalModel(float(identified["tau [s]"].mean()), float(identified["gamma [K/W]"].mean()))
    T_amb = float(identified["T_amb [°C]"].mean())
    write_json({"identified": True, "tau": model_fit.tau, "gamma": model_fit.gamma, "T_amb": T_amb,
                "provenance": provenance(inputs)}, out["thermal_model"])
    freq_of = {Path(p).stem: float(f) for f, p in freq_series.items()}
    trend = ch7.steady_rise_trends(identified, freq_of)
    write_table(trend, out["freq_trend"], inputs=inputs)
    vtrend = ch7.voltage_trend(read_series(volt_series), volt_segments, model_fit)
    write_table(vtrend, out["volt_trend"], inputs=inputs)
    checks = {Path(p).stem: read_series(p) for p in check_series.values()}
    write_table(ch7.prediction_errors(checks, model_fit, T_amb), out["prediction"], inputs=inputs)
    built = {
        "fig_7_2": figures.loop([trend["frequency [Hz]"]] * 2, [trend["steady rise [K]"],
                                trend["fit slope [K/Hz]"] * trend["frequency [Hz]"] + trend["fit intercept [K]"]],
                                "frequency [Hz]", "steady rise [K]",
                                f"Steady rise against frequency (linear fit R² = {trend['fit R²'].iloc[0]:.4f})",
                                labels=["identified γ·P", "linear fit"]),
        "fig_7_3": figures.loop([vtrend["voltage [V]"] ** 2], [vtrend["steady rise [K]"]], "V² [V²]", "steady rise [K]",
                                f"Steady rise against V² at 150 Hz (R² = {vtrend['fit R²'].iloc[0]:.4f})"),
    }
    for n, (name, s) in zip((5, 6), checks.items()):
        T_pred = predict_temperature(s["time"], s["P_PS"], model_fit, T0=T_amb, T_amb=T_amb)
        built[f"fig_7_{n}"] = figures.time_traces(s["time"], [(s["T_mid"], "T measured [°C]"), (T_pred, "T_SH(PS) [°C]"),
                                                              (T_pred - s["T_mid"], "error [K]")],
                                                  f"{name}: measured against predicted temperature")
    return built


def main(freq_series, volt_series, check_series, manifest, model, volt_segments, out, out_dir, log=None):
    """freq_series: {frequency [Hz]: path}; check_series: {run: path} for Figs 7.5–7.6."""
    logger = script_logging(log)
    meta = load_dataset(Path(manifest).parent.parent, Path(manifest).parent.name)
    th = meta["actuator"]["thermal"]
    props = ThermalProperties(th["rho"], th["c"], th["volume_m3"], th["area_m2"])
    k_over_alpha = json.loads(Path(model).read_text())["k_over_alpha"]
    runs = {Path(p).stem: read_series(p) for p in freq_series.values()}
    per_run, fits = ch7.identify(runs, props, T_amb=None)
    inputs = [*freq_series.values(), volt_series, *check_series.values(), manifest, model]
    write_table(per_run, out["per_run"], inputs=inputs)
    identified = per_run.dropna(subset=["tau [s]"]) if "tau [s]" in per_run else per_run.iloc[0:0]
    figs = {"fig_7_1": figures.loop([s["time"] for s in runs.values()], [s["T_mid"] for s in runs.values()],
                                    "time [s]", "T [°C]", "Self-heating at 100 V, 20–200 Hz", labels=list(runs))}
    if identified.empty:  # e.g. the smoke campaign's short runs: the later stages skip, and say why
        reason = "no heating run long enough to identify τ and γ (see per_run.csv)"
        logger.warning(reason)
        for key in ("table_7_1", "freq_trend", "volt_trend", "prediction"):
            write_table(pd.DataFrame([{"note": f"not computed: {reason}"}]), out[key], inputs=inputs)
        write_json({"identified": False, "reason": reason, "provenance": provenance(inputs)}, out["thermal_model"])
        for n in (2, 3, 5, 6):
            figs[f"fig_7_{n}"] = figures.placeholder(f"Figure 7.{n}", reason)
        built = figs
    else:
        built = figs | _identified(identified, freq_series, volt_series, check_series, k_over_alpha, volt_segments,
                                   out, inputs)
    for name, fig in built.items():
        save_figure(fig, Path(out_dir) / f"{name}.png", inputs=inputs)
    logger.info("\n%s", per_run.to_string())


if "snakemake" in globals():
    i, p = snakemake.input, snakemake.params
    main(dict(zip(p.freqs, i.freq_series)), i.volt_series, dict(zip(p.checks, i.check_series)), i.manifest, i.model,
         p.volt_segments, dict(snakemake.output.items()), p.out_dir, snakemake.log[0])
