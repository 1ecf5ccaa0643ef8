"""What the import and its readers share: the refusal, where a channel is in a file, the
arguments of ``selfsense import`` parsed, and what a reader offers the import.

Every refusal is an :class:`ImportProblem`: one line naming the file or the argument and, where it
can, what to type instead. A :class:`Column` says where a channel (or the time) is in the source
file, by a header name, a variable path or a TDMS channel, or by its position counted from 1, as
people count them, and its unit there, which :data:`UNITS` converts to the contract's. The
``parse_*`` functions and :func:`scalings` read the command line's ``--channel``, ``--time``,
``--range``, ``--scale``, ``--gain`` and ``--attr`` into these.

A reader (:mod:`selfsense.io.csv_source`, :mod:`selfsense.io.mat_source`,
:mod:`selfsense.io.tdms_source`) offers what :class:`Source` lists, in chunks of at most
:data:`CHUNK_ROWS` rows, so that the import judges every format alike. The readers import this
module and the import imports them; none of them imports the import back.
"""

from __future__ import annotations

import math
import re
import shlex
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol

import numpy as np

from selfsense.io.capture import CHANNEL_UNITS

#: factor from each accepted unit to the contract's unit of its quantity
UNITS: dict[str, dict[str, float]] = {
    "V": {"V": 1.0, "mV": 1e-3, "kV": 1e3},
    "A": {"A": 1.0, "mA": 1e-3, "uA": 1e-6, "µA": 1e-6, "nA": 1e-9, "pA": 1e-12},
    "m": {"m": 1.0, "mm": 1e-3, "um": 1e-6, "µm": 1e-6, "nm": 1e-9},
    "N": {"N": 1.0, "kN": 1e3, "mN": 1e-3},
    "degC": {"degC": 1.0, "°C": 1.0, "C": 1.0},
    "s": {"s": 1.0, "ms": 1e-3, "us": 1e-6, "µs": 1e-6},
}

#: a value this large in the source's unit (or ±inf) is a DAQ's overload sentinel (Keysight's
#: 9.9E+37, 1e308), not a measurement: stored as missing and counted
OVERLOAD = 1e30
#: fs given (--fs, --time) and fs declared by the file (a TDMS channel's wf_increment) agree to
#: this (relative): both describe one clock
DECLARED_FS_RTOL = 1e-6
#: rows a chunk holds at most: a reader yields its columns in chunks, so that memory does not grow
#: with the file's length (a CSV's chunk holds fewer rows of a wide file: its cells are limited)
CHUNK_ROWS = 1 << 18
#: how many varying columns a refusal of a constant one lists
LISTED = 12
#: what --scale and --gain record as a channel's scale_kind
SCALE_KINDS = {"--scale": "sensitivity", "--gain": "gain"}


class ImportProblem(ValueError):
    """An input the import cannot turn into a capture; one line naming the file and the problem."""


@dataclass(frozen=True)
class Column:
    """Where a channel (or the time) is in the source file, and its unit there. ``source``: a
    header name, variable path or TDMS channel (str), or a position counted from 1 (int)."""

    name: str  # contract channel, or "time"
    source: str | int
    unit: str

    @property
    def quantity(self) -> str:
        return "s" if self.name == "time" else CHANNEL_UNITS[self.name][0]

    @property
    def factor(self) -> float:
        """From the source's unit to the contract's."""
        return UNITS[self.quantity][self.unit]

    @property
    def spelled(self) -> str:
        """The source as it is typed: a position as its number, a name made of digits with '#'."""
        if isinstance(self.source, int):
            return str(self.source)
        return f"#{self.source}" if self.source.isdigit() else self.source

    def typed(self, unit: str | None = None) -> str:
        """The --channel (or --time) argument, shell-quoted, with another unit if given."""
        text = f"{self.spelled}:{unit or self.unit}"
        return shlex.quote(text if self.name == "time" else f"{self.name}={text}")


def parse_column(text: str, time: bool = False) -> Column:
    """``U=Voltage:V``, ``x_laser=2:um`` (the second column: digits are always a position,
    counted from 1), ``U=#7:V`` (the header's column named 7) or, for the time, ``t:ms``."""
    name, _, rest = ("time=" + text if time else text).partition("=")
    source, _, unit = rest.rpartition(":")
    if not (name and source and unit):
        raise ImportProblem(
            f"{text!r}: expected {'COLUMN:UNIT' if time else 'CHANNEL=COLUMN:UNIT'}"
        )
    if not time and name not in CHANNEL_UNITS:
        raise ImportProblem(
            f"{text!r}: unknown channel {name!r} (the contract's: {', '.join(CHANNEL_UNITS)})"
        )
    quantity = "s" if time else CHANNEL_UNITS[name][0]
    if unit not in UNITS[quantity]:
        raise ImportProblem(
            f"{text!r}: unit {unit!r} is not one of {quantity}'s ({', '.join(UNITS[quantity])})"
        )
    if source.isascii() and source.isdigit():
        if int(source) == 0:
            first = f"1:{unit}" if time else f"{name}=1:{unit}"
            raise ImportProblem(
                f"{text!r}: columns are counted from 1, as people count them: the first column "
                f"is 1 (type {first})"
            )
        return Column(name, int(source), unit)
    if re.fullmatch(r"#[0-9]+", source):  # a header name made of digits
        return Column(name, source[1:], unit)
    return Column(name, source, unit)


def parse_range(text: str) -> tuple[str, tuple[float, float]]:
    """``x_laser=-1e-4,1e-4`` (contract units) → ("x_laser", (-1e-4, 1e-4))."""
    channel, _, rest = text.partition("=")
    try:
        lo, hi = (float(v) for v in rest.split(","))
    except ValueError:
        raise ImportProblem(
            f"--range {text!r}: expected CHANNEL=LOW,HIGH in the contract's unit"
        ) from None
    if channel not in CHANNEL_UNITS or not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
        raise ImportProblem(f"--range {text!r}: a contract channel and finite LOW < HIGH")
    return channel, (lo, hi)


def parse_factor(text: str, option: str = "--scale") -> tuple[str, float]:
    """``U=20`` → ("U", 20.0): the recorded column times the factor is the channel's quantity
    in the --channel's unit. Finite and nonzero (negative: an inverting amplifier)."""
    channel, sep, value = text.partition("=")
    try:
        factor = float(value)
    except ValueError:
        factor = math.nan
    if not sep or channel not in CHANNEL_UNITS or not math.isfinite(factor) or factor == 0:
        raise ImportProblem(
            f"{option} {text!r}: expected CHANNEL=FACTOR, a contract channel and a finite, "
            "nonzero number (e.g. U=20)"
        )
    return channel, factor


def scalings(
    scales: Sequence[tuple[str, float]] = (), gains: Sequence[tuple[str, float]] = ()
) -> dict[str, tuple[float, str]]:
    """--scale and --gain as {channel: (factor, kind)}; one factor per channel."""
    out: dict[str, tuple[float, str]] = {}
    for option, given in (("--scale", scales), ("--gain", gains)):
        for channel, factor in given:
            if channel in out:
                raise ImportProblem(
                    f"{option} {channel}={factor:g}: {channel} has a factor already: give one "
                    "--scale or --gain per channel (their product, if both apply)"
                )
            out[channel] = (float(factor), SCALE_KINDS[option])
    return out


def parse_attr(text: str) -> tuple[str, Any]:
    """``warmup_s=0.5`` → ("warmup_s", 0.5): numbers as numbers, the rest as text."""
    key, sep, value = text.partition("=")
    if not (sep and re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", key)):
        raise ImportProblem(f"--attr {text!r}: expected NAME=VALUE")
    for kind in (int, float):
        try:
            return key, kind(value)
        except ValueError:
            continue
    return key, value


def source_labels(columns: Sequence[Column], spelled) -> dict[str, str]:
    """{channel: how a refusal names where it is}: ``spelled(column)`` ("column 3", "variable
    'data[2]'"), and the channel it is for but the time's."""
    return {c.name: spelled(c) + ("" if c.name == "time" else f" ({c.name})") for c in columns}


def one_length(path: Path, what: str, labels: Mapping[str, str], lengths: Mapping[str, int]) -> int:
    """The one length all the requested ``what`` (variables, channels) share, or one line naming
    each one's."""
    if len(set(lengths.values())) != 1:
        raise ImportProblem(
            f"{path}: the {what} differ in length ("
            + ", ".join(f"{labels[k]}: {n}" for k, n in lengths.items())
            + ")"
        )
    return next(iter(lengths.values()))


def one_column_each(
    path: Path, labels: Mapping[str, str], places: Mapping[str, Any], what: str = "column"
) -> None:
    """Refuse two channels (or a channel and the time) read from one place of the file: the
    capture would hold one recording under two names, and an analysis would compare it with
    itself (x against U: a gain of exactly 1, a stroke of the drive's span)."""

    def named(name: str) -> str:
        return f"the time {labels[name]}" if name == "time" else labels[name]

    seen: dict[Any, str] = {}
    for name, place in places.items():
        if place in seen:
            raise ImportProblem(
                f"{path}: {named(seen[place])} and {named(name)} are one {what} of the file: "
                f"each channel needs a {what} of its own"
            )
        seen[place] = name


def listed(items: Sequence[str]) -> str:
    """Items for a refusal's one line: the first LISTED of them, and how many in all."""
    return ", ".join(items[:LISTED]) + (f", … ({len(items)} in all)" if len(items) > LISTED else "")


def column_spans(values: np.ndarray, axis: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """The least and largest value along ``axis`` of each column, overloads and NaN left out
    (inf and -inf where a column has none)."""
    values = np.where(np.abs(values) < OVERLOAD, values, np.nan)
    return (
        np.fmin.reduce(values, axis=axis, initial=np.inf),
        np.fmax.reduce(values, axis=axis, initial=-np.inf),
    )


def short_error(err: BaseException) -> str:
    """An error a library raised, for a refusal's one line: its type and its first 200
    characters."""
    return f"{type(err).__name__}: {' '.join(str(err).split())[:200]}"


class Source(Protocol):
    """What the import asks of a reader: opened on a file, every requested column located and its
    type checked, nothing read yet (but a v4–v7 ``.mat`` file, which scipy loads whole)."""

    #: the file
    path: Path
    #: what a refusal calls the file: "CSV", "TSV", "MATLAB", "MATLAB v7.3", "TDMS"
    kind: str
    #: what a refusal calls a sample: "rows" or "samples"
    rows: str
    #: per channel (and "time"), how a refusal names its column
    labels: dict[str, str]
    #: the rate the file states (fs [Hz], where it states it), or None
    declared_fs: tuple[float, str] | None
    #: what the reader left out of the file and why, for the capture's import_note ("" if
    #: nothing)
    note: str

    def chunks(self, progress: bool = False) -> Iterator[tuple[int, dict[str, np.ndarray]]]:
        """(first row of the chunk, {name: the column's values as float64, NaN where empty}), in
        chunks of the requested columns only; ``progress``: log how far a pass has come."""

    def varying(self, name: str) -> str:
        """For the refusal of a constant column: the columns of the file that vary ("" if the
        reader cannot tell)."""
