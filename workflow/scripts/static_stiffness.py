"""Rule `static_stiffness`: k from the blocked-force and free-stroke holds at U_max (Eq 4.16)."""

import numpy as np
import pandas as pd

from selfsense.chapters.ch4 import STATIC_K
from selfsense.io.capture import open_capture
from selfsense.io.provenance import run, script_logging, write_table
from selfsense.methods.electromech import hold_rise, static_stiffness


def rise(capture, channel, t_hold):
    with open_capture(capture, require=(channel,)) as cap:
        values = cap.read((channel,))[channel]
        return hold_rise(values, np.arange(cap.n) / cap.fs, t_hold)


def main(free, blocked, table, t_hold, inputs, log=None):
    logger = script_logging(log)
    x_free, F_blocked = rise(free, "x_laser", t_hold), rise(blocked, "F", t_hold)
    k = static_stiffness(F_blocked, x_free)
    result = pd.DataFrame(
        [{"x_free [µm]": x_free * 1e6, "F_blocked [N]": F_blocked, STATIC_K: k * 1e-6}]
    )
    write_table(result, table, inputs=inputs, config={"t_hold": t_hold})
    logger.info("static stiffness %.3f N/µm", k * 1e-6)


if "snakemake" in globals():
    run(main, snakemake)
