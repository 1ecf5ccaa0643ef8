"""The record lengths the thesis's printed degrees of freedom fix: Table 5.2's total df is the
0.1 Hz run's non-overlapping ripple windows less one, Table 7.3's the 50 Hz run's drive at one
window in ``thermal.gamma_t_every`` less one, both from the shipped protocols, the dataset's DAQ
and config.yaml, against the numbers workflow/scorecard.yaml quotes."""

import yaml

from ..helpers import ROOT


def load(path):
    return yaml.safe_load((ROOT / path).read_text(encoding="utf-8"))


def printed_total_df(source):
    """The registry's published total df of one table."""
    for group in load("workflow/scorecard.yaml")["groups"]:
        for entry in group.get("entries", []):
            if group["source"] == source and entry.get("quantity") == "total df":
                return entry["published"]
    raise AssertionError(f"no total df for {source}")


def test_the_records_give_the_printed_degrees_of_freedom():
    daq = load("raw/pi_p885/dataset.yaml")["daq"]
    periods_per_s = daq["fs"] / daq["ripple"]["ns"]
    config = load("config.yaml")
    ch5 = load("workflow/protocols/ch5.yaml")["experiments"]["ch5_sine_0p1hz"]
    windows = ch5["segments"][0]["duration"] * periods_per_s / config["ripple"]["n_periods"]
    assert windows - 1 == printed_total_df("Table 5.2")
    ch7 = load("workflow/protocols/ch7.yaml")["experiments"]["ch7_freq_50hz"]
    kept = ch7["segments"][0]["duration"] * periods_per_s / config["thermal"]["gamma_t_every"]
    assert kept - 1 == printed_total_df("Table 7.3")
