"""Rule `ch7_summary`: the coupled estimation's errors beside the thesis (mixed run: 1.38 µm,
4.18 %, 1.45 °C), Figures 7.10–7.12, and τ, γ, k_T against the twin's truth.

Alone: run through Snakemake (`snakemake results/pi_p885/ch7/coupled.csv`).
"""

import json
from pathlib import Path

import pandas as pd

from selfsense import figures
from selfsense.capture import open_capture, read_series
from selfsense.provenance import save_figure, script_logging, write_table

THESIS_MIXED = {"max observer error [µm]": 1.38, "max observer error [% of stroke]": 4.18,
                "max |T_SH_HPO − T| [K]": 1.45, "max |T_SH_PS − T| [K]": 1.45}


def main(stats, traces, table_7_1, truth_capture, out, out_dir, log=None):
    """stats / traces: {run: path}."""
    logger = script_logging(log)
    rows = []
    for run, path in stats.items():
        s = {k: v for k, v in json.loads(Path(path).read_text()).items() if k != "provenance"}
        rows.append({"run": run} | s | ({f"thesis {k}": v for k, v in THESIS_MIXED.items()} if run == "ch7_mixed_ae" else {}))
    write_table(pd.DataFrame(rows), out["coupled"], inputs=list(stats.values()))
    for n, run in zip((10, 11, 12), ("ch7_freq_100hz", "ch7_freq_50hz", "ch7_mixed_ae")):
        tr = read_series(traces[run])
        if not len(tr["time"]):
            fig = figures.placeholder(f"Figure 7.{n}", json.loads(Path(stats[run]).read_text())["note"])
        else:
            fig = figures.time_traces(tr["time"], [(tr["T_mid"], "T measured [°C]"), (tr["T_SH_PS"], "T_SH(PS) [°C]"),
                                                   (tr["T_SH_HPO"], "T_SH(HPO) [°C]"),
                                                   (tr["T_SH_HPO"] - tr["T_mid"], "T_SH(HPO) − T [K]")],
                                      f"{run}: temperature from the laser and from the observer")
        save_figure(fig, Path(out_dir) / f"fig_7_{n}.png", inputs=[traces[run]])
    t71 = pd.read_csv(table_7_1)
    identified = t71.set_index("parameter")["reproduced"] if "parameter" in t71 else pd.Series(dtype=float)
    with open_capture(truth_capture) as cap:
        truth, _ = cap.read_truth()
    recovery = pd.DataFrame([
        {"parameter": name, "truth": float(truth[attr]), "identified": float(identified.get(key, float("nan"))),
         "error [%]": 100 * (float(identified.get(key, float("nan"))) / float(truth[attr]) - 1)}
        for name, attr, key in (("tau [s]", "thermal_tau", "tau [s]"), ("gamma [K/W]", "thermal_gamma", "gamma [K/W]"),
                                ("k_T [W/(m² K)]", "thermal_k_T", "k_T [W/(m² K)]"))])
    write_table(recovery, out["recovery"], inputs=[table_7_1, truth_capture])
    logger.info("\n%s\n%s", pd.DataFrame(rows).to_string(), recovery.to_string())


if "snakemake" in globals():
    i, p = snakemake.input, snakemake.params
    main(dict(zip(p.runs, i.stats)), dict(zip(p.runs, i.traces)), i.table_7_1, i.truth_capture,
         dict(snakemake.output.items()), p.out_dir, snakemake.log[0])
