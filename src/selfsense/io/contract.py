"""A capture against its dataset's manifest
(docs/capture-contract.md, "Agreement with the manifest").

The manifest declares what the DAQ records: its sampling rate, its channels (``daq.channels``,
and the controller's logged channels by their ``daq.ranges``), optionally each sensor's units,
and, through the stages the dataset runs, the capture attributes its analyses read. A capture
that says otherwise stops at its QC with one line naming both files, before any analysis reads
it; so does a channel clipped in more than :data:`CLIP_LIMIT` of its samples, whose numbers an
analysis would silently flatten. The checks only read: measured captures are never modified.
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping
from typing import Any

from selfsense.io.capture import CHANNEL_UNITS, FS_RTOL, CaptureError, Header, sampling_rate

#: the largest fraction of a channel's samples that may sit at the ADC's full scale
CLIP_LIMIT = 0.01

#: the usual slip that drives a channel of this unit into its rails (values 10³–10⁶ too large)
WRONG_UNIT = {
    "m": "µm written as m",
    "V": "mV written as V",
    "A": "mA written as A",
    "N": "mN written as N",
    "degC": "K written as degC",
}


def declared_channels(manifest: Mapping[str, Any]) -> set[str]:
    """daq.channels, and the channels only a range declares (what a real-time controller logs)."""
    return set(manifest["daq"]["channels"]) | set(manifest["daq"]["ranges"])


def required_attributes(manifest: Mapping[str, Any]) -> tuple[str, ...]:
    """The capture attributes this dataset's analyses read: the folding plan and the warm-up the
    ripple analyses discard (Eq 3.4–3.5), the drive mode and compensation of the Ronkanen runs."""
    needed: tuple[str, ...] = ()
    if "ripple" in manifest["daq"]:
        needed += ("fr_nominal", "ns", "nf", "warmup_s")
    if "ronkanen" in manifest["protocols"]:
        needed += ("drive_quantity", "compensation", "compensation_X")
    return needed


def check_agreement(
    path: os.PathLike | str,
    header: Header,
    manifest: Mapping[str, Any],
    manifest_path: os.PathLike | str,
) -> None:
    """fs, channels and units of a capture against its manifest; CaptureError in one line naming
    both files on the first difference."""

    def fail(problem: str) -> CaptureError:
        return _both(path, problem, manifest_path)

    fs = header.attrs.get("fs")
    declared_fs = float(manifest["daq"]["fs"])
    if fs is not None:  # text, several values or NaN: one line on the capture alone
        fs = sampling_rate(path, fs)
    if fs is not None and not math.isclose(fs, declared_fs, rel_tol=FS_RTOL):
        raise fail(f"fs = {fs:g} Hz, the manifest declares daq.fs = {declared_fs:g} Hz")
    extra = sorted(set(header.units) - declared_channels(manifest))
    if extra:
        raise fail(
            f"channel {extra[0]} is not declared in the manifest's daq.channels "
            f"({', '.join(manifest['daq']['channels'])})"
        )
    sensors = manifest.get("sensors", {})
    for channel, units in header.units.items():
        wanted = sensors.get(channel, {}).get("units", CHANNEL_UNITS[channel][0])
        if units != wanted:
            raise fail(f"channel {channel} is in {units!r}, the manifest declares {wanted!r}")


def check_attributes(
    path: os.PathLike | str,
    header: Header,
    manifest: Mapping[str, Any],
    manifest_path: os.PathLike | str,
) -> None:
    """The attributes this dataset's analyses read are all there (no default stands in for one)."""
    absent = [a for a in required_attributes(manifest) if a not in header.attrs]
    if absent:
        raise _both(
            path,
            f"global attribute {absent[0]} is missing: this dataset's analyses read it "
            "(docs/capture-contract.md)",
            manifest_path,
        )


def _both(path: os.PathLike | str, problem: str, manifest_path: os.PathLike | str) -> CaptureError:
    return CaptureError(f"{path}: {problem} ({manifest_path})")


def clipping_problem(
    channel: str,
    clipped: int,
    samples: int,
    lo: float,
    hi: float,
    manifest_path: os.PathLike | str,
    origin: str | None = None,
    factor: str = "",
) -> str | None:
    """Why a channel clipped in more than CLIP_LIMIT of its samples cannot be analysed, with the
    likely cause; None when it is within the limit. ``origin``: where the range was given, if not
    in the manifest (an import's --range); ``factor``: the option that scaled the values, if one
    did (it is as likely a cause as the unit)."""
    if samples == 0 or clipped <= CLIP_LIMIT * samples:
        return None
    unit = CHANNEL_UNITS[channel][0]
    slip = WRONG_UNIT.get(unit, "a wrong unit")
    return (
        f"channel {channel} is clipped in {100 * clipped / samples:.3g} % of its {samples} samples "
        f"(more than {100 * CLIP_LIMIT:g} %): the ADC range [{lo:g}, {hi:g}] {unit} "
        f"({origin or f'daq.ranges.{channel} in {manifest_path}'}) is too narrow, or the values "
        f"are in the wrong unit ({slip}?)"
        + (f", or {factor} is not their factor" if factor else "")
    )


def check_clipping(
    path: os.PathLike | str,
    clipped: Mapping[str, int],
    header: Header,
    manifest_path: os.PathLike | str,
) -> None:
    """CaptureError naming the first channel clipped beyond CLIP_LIMIT (counts from a scan, in
    which a missing sample, a code of the channel's _FillValue or missing_value, is never a
    clipped one)."""
    for channel, count in clipped.items():
        problem = clipping_problem(
            channel, count, header.samples[channel], *header.ranges[channel], manifest_path
        )
        if problem:
            raise CaptureError(f"{path}: {problem}")
