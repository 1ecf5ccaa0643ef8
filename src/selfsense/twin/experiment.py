"""The twin's entry point: one experiment of a simulated dataset's catalogue into its capture.

:func:`simulate_experiment` is the one entry point the workflow uses: it resolves a dataset's
manifest and an experiment of the catalogue into the twin's parameters, the DAQ plan
(:func:`daq_plan`) and the drive, and writes that experiment's capture with the stack's
:class:`~selfsense.twin.bench.Bench`, or with :mod:`selfsense.twin.bender` for a bender dataset.
The twin as a whole is described in :mod:`selfsense.twin` (docs/design.md, "The digital twin").
"""

from __future__ import annotations

import logging
import re
from collections.abc import Callable, Mapping
from pathlib import Path

from selfsense.io.capture import ScanReport, UnshrinkableChunk, compression_settings
from selfsense.io.manifest import (
    PROTOCOLS,
    ManifestError,
    catalogue,
    load_dataset,
    protocol_duration,
)
from selfsense.methods.drive import Drive, drive_from_protocol
from selfsense.twin.bench import Bench, Controller, DaqPlan, simulate_capture
from selfsense.twin.params import TwinParams

LOG = logging.getLogger("selfsense.twin")

#: the most samples (per fast channel) one simulated capture may have: 2**28 ≈ 268 M, 5 600 s at
#: the stack's 48 kHz. The thesis campaign's longest capture is Chapter 7's 150 Hz heating run,
#: 1 603 s or 77 M samples (≈ 1.5 GB of int16 channels before compression); its whole campaign is
#: ≈ 460 M samples, so a single capture past this bound, 3.5× the longest, is a typo or a drawn
#: override, not an experiment, and would fill a disk for hours before failing. Checked before
#: the writer opens, so nothing reaches raw/.
MAX_CAPTURE_SAMPLES = 1 << 28

__all__ = [
    "Bench",
    "Controller",
    "DaqPlan",
    "Drive",
    "TwinParams",
    "daq_plan",
    "simulate_capture",
    "simulate_experiment",
]


def daq_plan(manifest: Mapping) -> DaqPlan:
    daq = manifest["daq"]
    ripple = daq.get("ripple", {})
    return DaqPlan(
        fs=float(daq["fs"]),
        channels=tuple(daq["channels"]),
        ranges={k: (float(v[0]), float(v[1])) for k, v in daq["ranges"].items()},
        fr_nominal=ripple.get("fr_nominal"),
        ns=ripple.get("ns"),
        nf=ripple.get("nf"),
    )


def simulate_experiment(
    raw_dir: str | Path,
    dataset: str,
    experiment: str,
    config: Mapping,
    output: str | Path | None = None,
    controller_for: Callable[[DaqPlan, Drive, float], Controller] | None = None,
    drive_leak: bool = True,
    identified: Mapping[str, float] | None = None,
    identified_tables: tuple[str | Path, str | Path] | None = None,
) -> ScanReport:
    """Make raw/<dataset>/<experiment>.nc with the twin, as configured; returns its QC scan (the
    capture is validated as it is written, :meth:`selfsense.io.capture.CaptureWriter.scan_report`).
    ``drive_leak=False`` is a study's what-if (:class:`.bench.Bench`), never a capture of the
    campaign.

    A bender run whose protocol compensates with ``{R: identified, c: identified}`` (Eq 15) also
    needs ``identified``, the {"R", "c"} the pipeline identified from the other captures, or
    ``identified_tables``, the identification's tables they are read from (identified.csv,
    table_2.csv: :func:`selfsense.twin.bender.identified_compensation`): the twin's own R and c
    are never the operator's setting.

    Closed-loop experiments also need ``controller_for(daq, drive, warmup)``, which builds the
    bench's real-time loop (:func:`selfsense.twin.closed_loop.realtime_controller`). It is passed
    in rather than imported so that the open-loop twin does not depend on the self-sensing code it
    is there to test.
    """
    manifest = load_dataset(raw_dir, dataset)
    where = Path(raw_dir) / dataset / "dataset.yaml"
    if manifest["source"] != "simulated":
        raise ManifestError(
            f"{where}: source is {manifest['source']}; the twin never writes measured captures"
        )
    experiments = catalogue(manifest, config["campaign"], where)
    if experiment not in experiments:
        raise ManifestError(
            f"{where}: unknown experiment {experiment!r} for campaign {config['campaign']}"
        )
    exp = experiments[experiment]
    _check_capture_size(exp, manifest, where)
    cap = config["capture"]
    warmup = float(exp.protocol.get("warmup", 0.0))
    attrs = {
        "dataset": dataset,
        "protocol": exp.chapter,
        "campaign": config["campaign"],
        "description": manifest["description"].strip(),
        "warmup_s": warmup,
        "control": exp.control,
    }
    path = output or Path(raw_dir) / dataset / f"{experiment}.nc"
    settings = compression_settings(cap)
    try:
        return _simulate(
            path,
            manifest,
            exp,
            attrs,
            cap,
            settings,
            where,
            controller_for,
            drive_leak,
            identified,
            identified_tables,
        )
    except UnshrinkableChunk as err:
        # blosc fails on a chunk it cannot shrink; the twin is deterministic, so the same capture
        # is written again with zlib. A full disk, a quota, a read-only folder or a name too long
        # is a CaptureWriteError instead (CaptureWriter asks the file system why HDF5 failed):
        # no compression cures it, so it is never retried and stops here in its one line,
        # "<capture>: cannot write the capture: no space left on device"
        LOG.warning("%s; writing it again with zlib level 1", err)
        return _simulate(
            path,
            manifest,
            exp,
            attrs,
            cap,
            {"compression": "zlib", "complevel": 1},
            where,
            controller_for,
            drive_leak,
            identified,
        )


def _check_capture_size(exp, manifest: Mapping, where: Path) -> None:
    """Refuse, in one line naming the file and the key that set the run's length, a capture
    longer than :data:`MAX_CAPTURE_SAMPLES`, before anything is written."""
    fs = float(manifest["daq"]["fs"])
    duration = protocol_duration(exp.protocol)
    samples = duration * fs
    if samples <= MAX_CAPTURE_SAMPLES:
        return
    # the manifest's overrides of this run's protocol, if any, set its length; else its file
    entry = re.sub(r"_s[0-9]+$", "", exp.name)  # a set's runs are <entry>_s<k>
    prefix = f"{exp.chapter}:experiments.{entry}."
    keys = [k for k in manifest.get("protocol_overrides", {}) if k.startswith(prefix)]
    source = (
        f"{where}: key protocol_overrides.{' and '.join(keys)}"
        if keys
        else f"{PROTOCOLS / exp.chapter}.yaml: key experiments.{entry}"
    )
    raise ManifestError(
        f"{source}: experiment {exp.name} would record {samples:.4g} samples "
        f"({duration:.6g} s at daq.fs = {fs:g} Hz), more than a capture may hold "
        f"({MAX_CAPTURE_SAMPLES}, selfsense.twin.experiment.MAX_CAPTURE_SAMPLES; the thesis's "
        "longest has 77 M): shorten its segments, repeat or warmup",
        "protocol_overrides" if keys else f"experiments.{entry}",
    )


def _simulate(
    path,
    manifest,
    exp,
    attrs,
    cap,
    compression,
    where,
    controller_for,
    drive_leak=True,
    identified=None,
    identified_tables=None,
) -> ScanReport:
    """One run of the experiment into ``path`` with the writer's ``compression`` arguments."""
    if manifest["model"] == "bender":
        # here: its analysis imports (pandas, scipy.optimize) cost a stack's simulation ≈ 0.4 s
        from selfsense.twin import bender

        if identified is None and identified_tables:
            identified = bender.identified_compensation(*identified_tables)
            LOG.info(
                "Eq 15 compensation as identified: R = %.6g Ohm, c = %.6g 1/A (%s)",
                identified["R"],
                identified["c"],
                ", ".join(map(str, identified_tables)),
            )
        return bender.simulate_experiment(
            path,
            manifest["twin"],
            daq_plan(manifest),
            exp,
            attrs,
            manifest.get("seed", 0),
            cap,
            compression,
            f"{where}: twin",
            identified,
        )
    params = TwinParams.from_manifest(manifest["twin"], f"{where}: twin")
    daq = daq_plan(manifest)
    drive = drive_from_protocol(exp.protocol)
    controller = None
    if exp.control == "closed_loop":
        if controller_for is None:
            raise ManifestError(
                f"{where}: experiment {exp.name} needs the real-time controller's Γ, a0 and k/α"
            )
        controller = controller_for(daq, drive, float(exp.protocol.get("warmup", 0.0)))
    return simulate_capture(
        path,
        params,
        daq,
        drive,
        attrs,
        manifest.get("seed", 0),
        exp.name,
        load_stiffness=exp.load_stiffness,
        controller=controller,
        chunk_len=cap["chunk_len"],
        truth_decimation=cap["truth_decimation"],
        drive_leak=drive_leak,
        **compression,
    )
