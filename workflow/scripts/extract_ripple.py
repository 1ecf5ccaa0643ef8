"""Rule `extract_ripple`: C_e, R_e (Eq 3.6–3.13) and window means of U, x, I, q for one capture."""

from selfsense.io.capture import CaptureError, SeriesWriter, open_capture
from selfsense.io.provenance import run, script_logging
from selfsense.methods.ripple import SERIES_UNITS, impedance_series, plan_from_capture

COMPANIONS = ("U", "x_laser", "I")


def main(capture, series, n_periods, chunk_len=1 << 18, log=None):
    logger = script_logging(log)
    with open_capture(capture, require=("Ur", "Ir") + COMPANIONS) as cap:
        try:  # also refuses a folded ripple inside the mechanical bandwidth
            plan = plan_from_capture(cap, n_periods)
        except ValueError as err:
            raise CaptureError(f"{capture}: {err}") from None
        window = f"one window of np·ns = {plan.n_periods}·{plan.ns} samples"
        cap.require_samples(plan.block_len, f"ripple extraction ({window})")
        chunks = cap.iter_chunks(("Ur", "Ir") + COMPANIONS, chunk_len)
        attrs = {"capture": str(capture), "np": plan.n_periods, "fr_nominal": plan.fr, "fs": cap.fs}
        config = {"n_periods": n_periods}
        with SeriesWriter(series, SERIES_UNITS, attrs, inputs=[capture], config=config) as out:
            for block in impedance_series(chunks, plan, cap.fs, COMPANIONS):
                out.write(block)
        logger.info(
            "%s: %d ripple windows (np = %d), NaN %s", capture, out.n, plan.n_periods, cap.stats.nan
        )


if "snakemake" in globals():
    run(main, snakemake)
