"""A lab's own recording into the capture contract (docs/bring-your-own-data.md).

Reads CSV/TSV (columns by name or index) or MATLAB ``.mat`` files up to v7 (``scipy.io.loadmat``;
variables by name, struct fields by ``.``, a column of a matrix or an element of a struct array by
``[k]``), converts each channel to its contract unit, checks the time axis, packs int16 with the
manifest's ranges (or ranges derived from the data) and writes ``raw/<dataset>/<experiment>.nc``,
then scaffolds or updates ``raw/<dataset>/dataset.yaml``.

Everything is judged before anything is published: the arguments (fs, names, ranges), the file's
layout (the header's columns against the data rows'), every cell of the columns asked for
(numeric, not complex, a column not all empty), overload sentinels (``9.9E+37``, ``1e308``, ±inf:
stored as missing and counted, refused beyond :data:`~selfsense.io.contract.CLIP_LIMIT` of a
channel) before a range is derived from the data, the time axis against a least-squares line
through it, the clipping against the ranges. A CSV is read twice in chunks, only its requested
columns: a first pass checks and sums up, the second streams into the capture, so memory does not
grow with the file's length (a ``.mat`` file is loaded whole by scipy). Imports into one dataset
take its lock (``raw/<dataset>/.import.lock``, ``fcntl.flock``) and run one after another. The
capture is written to a hidden temporary, read back, and linked to its name only if no file has
it (an existing capture is never overwritten); the manifest follows by an atomic rename. A failure
leaves nothing behind: no capture, no temporary, no manifest change, no new folder. Every refusal
is an :class:`ImportProblem`, one line naming the file or the argument.
"""

from __future__ import annotations

import codecs
import csv
import errno
import fcntl
import logging
import math
import os
import re
import time
import warnings
from collections.abc import Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from selfsense import __version__
from selfsense.io.capture import (
    CHANNEL_UNITS,
    MIN_SAMPLES,
    SLOW_CHANNELS,
    CaptureError,
    CaptureWriter,
    channel_spec,
    open_capture,
)
from selfsense.io.contract import CLIP_LIMIT, clipping_problem
from selfsense.io.manifest import (
    ManifestError,
    check_dataset_name,
    check_experiment_name,
    load_dataset,
    validate_document,
)
from selfsense.io.provenance import atomic_path, temporary_path

LOG = logging.getLogger("selfsense.io.importer")

#: factor from each accepted unit to the contract's unit of its quantity
UNITS: dict[str, dict[str, float]] = {
    "V": {"V": 1.0, "mV": 1e-3, "kV": 1e3},
    "A": {"A": 1.0, "mA": 1e-3, "uA": 1e-6, "µA": 1e-6, "nA": 1e-9, "pA": 1e-12},
    "m": {"m": 1.0, "mm": 1e-3, "um": 1e-6, "µm": 1e-6, "nm": 1e-9},
    "N": {"N": 1.0, "kN": 1e3, "mN": 1e-3},
    "degC": {"degC": 1.0, "°C": 1.0, "C": 1.0},
    "s": {"s": 1.0, "ms": 1e-3, "us": 1e-6, "µs": 1e-6},
}
#: a derived ADC range leaves this fraction of the data's span free on each side
RANGE_MARGIN = 0.1
#: a derived range spans at least this fraction of the data's magnitude (a constant channel)
MIN_RELATIVE_SPAN = 1e-6
#: a value this large in the source's unit (or ±inf) is a DAQ's overload sentinel (Keysight's
#: 9.9E+37, 1e308), not a measurement: stored as missing and counted
OVERLOAD = 1e30
#: the time axis may stray this many samples from the least-squares line through it (as the
#: capture contract's time axis may)
TIME_TOLERANCE = 0.25
#: dataset and experiment names are at most this long: they become file names, to which the
#: capture's two temporaries add up to 114 characters, and a file name has at most 255 bytes
MAX_NAME = 100
#: how long an import waits for another import into the same dataset to finish [s]
LOCK_TIMEOUT_S = 600.0
LOCK_NAME = ".import.lock"
#: cells a CSV chunk holds (rows × fields: the tokenizer keeps every field of a chunk's rows, also
#: the ones not read), and at most this many rows
CSV_CHUNK_CELLS = 1 << 22
CSV_CHUNK_ROWS = 1 << 18
#: data rows whose field count is compared with the header's, besides the last
CHECKED_ROWS = 10
PROGRESS_STEP = 0.1
#: capture attributes the import sets itself (an --attr may not)
OWN_ATTRS = frozenset(
    {
        "dataset",
        "experiment",
        "fs",
        "source",
        "software_version",
        "imported_from",
        "import_note",
        "Conventions",
        "clipped_samples",
    }
)


class ImportProblem(ValueError):
    """An input the import cannot turn into a capture; one line naming the file and the problem."""


@dataclass(frozen=True)
class Column:
    """Where a channel (or the time) is in the source file, and its unit there."""

    name: str  # contract channel, or "time"
    source: str | int  # column name or index (CSV), variable path (MAT)
    unit: str

    @property
    def factor(self) -> float:
        """From the source's unit to the contract's."""
        return UNITS["s" if self.name == "time" else CHANNEL_UNITS[self.name][0]][self.unit]


def parse_column(text: str, time: bool = False) -> Column:
    """``U=Voltage:V``, ``x_laser=2:um`` (column index 2) or, for the time, ``t:ms``."""
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
    return Column(name, int(source) if source.isdigit() else source, unit)


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


def parse_separator(text: str) -> str:
    """One character that cannot be part of a number; ``\\t`` as typed in a shell is a tab."""
    sep = "\t" if text in ("\\t", "tab") else text
    if not (
        len(sep) == 1
        and (sep == "\t" or sep.isprintable())
        and not sep.isalnum()
        and sep not in '.+-"'
    ):
        raise ImportProblem(
            f"--sep {text!r}: one character that cannot be part of a number "
            "(',', ';', '|', ' ' or '\\t')"
        )
    return sep


# -- the sources: a CSV streamed in chunks, a .mat file whole --------------------------------------


class _CsvSource:
    """The requested columns of a CSV/TSV file, located by its header and read in chunks.

    The header's field count is compared with the first CHECKED_ROWS data rows' and the last
    one's: data rows that end in one more, empty field (a separator at the end of every data row,
    the header without it) keep their columns; any other difference is refused. Columns are read
    by position, so nothing shifts."""

    def __init__(self, path: Path, columns: Sequence[Column], sep: str | None, header: bool):
        self.path, self.header = path, header
        self.sep = parse_separator(sep) if sep else self._default_separator(path)
        self.kind = "TSV" if self.sep == "\t" else "CSV"
        self.encoding = self._encoding(path)
        names, self.width, self.skip = self._layout()
        self.positions = {c.name: self._position(c, names) for c in columns}
        self.labels = {
            c.name: f"column {c.source!r}" + ("" if c.name == "time" else f" ({c.name})")
            for c in columns
        }
        self.chunk_rows = int(min(CSV_CHUNK_ROWS, max(64, CSV_CHUNK_CELLS // self.width)))

    @staticmethod
    def _default_separator(path: Path) -> str:
        return "\t" if path.suffix.lower() in (".tsv", ".tab") else ","

    @staticmethod
    def _encoding(path: Path) -> str:
        """UTF-8 (a byte-order mark skipped) if the file's first MiB is, else Latin-1 (a header
        written on Windows: 'x [µm]' in cp1252 or Latin-1 reads the same)."""
        with open(path, "rb") as raw:
            head = raw.read(1 << 20)
        try:
            codecs.getincrementaldecoder("utf-8-sig")().decode(head, final=False)
        except UnicodeDecodeError:
            return "latin-1"
        return "utf-8-sig"

    def _unreadable(self, err: BaseException) -> ImportProblem:
        return ImportProblem(
            f"{self.path}: not a readable {self.kind} file ({' '.join(str(err).split())[:200]})"
        )

    def _reader(self, lines) -> Iterator[list[str]]:
        return csv.reader(lines, delimiter=self.sep, skipinitialspace=self.sep != " ")

    def _layout(self) -> tuple[list[str] | None, int, int]:
        """The header's names (None without one), the number of fields a data row has, and the
        lines before the first data row."""
        try:
            with open(self.path, newline="", encoding=self.encoding, errors="replace") as text:
                reader = self._reader(text)
                rows: list[tuple[int, list[str]]] = []
                names, skip = None, 0
                for row in reader:
                    if not row:  # a blank line
                        continue
                    if self.header and names is None:
                        names, skip = row, reader.line_num
                        continue
                    rows.append((len(rows) + 1, row))
                    if len(rows) >= CHECKED_ROWS:
                        break
                last = self._last_row()
        except csv.Error as err:
            raise self._unreadable(err) from None
        if self.header and names is None:
            raise ImportProblem(f"{self.path}: empty file (no header, no data)")
        if not rows:
            raise ImportProblem(f"{self.path}: no data rows")
        if names is not None:
            if len(names) > 1 and names[-1].strip() == "":
                names = names[:-1]  # the header ends in the separator
            width, against = len(names), f"the header has {len(names)}"
        else:
            width, against = len(rows[0][1]), f"data row 1 has {len(rows[0][1])}"
        if last is not None and len(rows) == CHECKED_ROWS:
            rows.append(("the last", last))
        trailing = False
        for k, row in rows:
            if len(row) == width + 1 and row[-1].strip() == "":
                trailing = True  # one more, empty field: the row ends in the separator
            elif len(row) != width:
                where = f"data row {k}" if isinstance(k, int) else "the last data row"
                hint = (
                    f"; the header may lack a column (data rows have {len(row) - width} more)"
                    if names is not None and len(row) > width
                    else ""
                )
                raise ImportProblem(
                    f"{self.path}: {where} has {len(row)} fields, {against} (separator "
                    f"{self.sep!r}: --sep if it is another){hint}"
                )
        if trailing:
            LOG.info(
                "%s: data rows end in the separator: their empty last field is ignored", self.path
            )
        return names, width, skip

    def _last_row(self) -> list[str] | None:
        """The file's last non-blank line as fields (None if it is longer than 1 MiB)."""
        with open(self.path, "rb") as raw:
            size = raw.seek(0, os.SEEK_END)
            block = min(size, 1 << 20)
            raw.seek(size - block)
            tail = raw.read(block).decode(self.encoding, errors="replace").splitlines()
        lines = [line for line in tail if line.strip()]
        if not lines or (block < size and len(lines) < 2):
            return None
        return next(self._reader([lines[-1]]), None)

    def _position(self, c: Column, names: list[str] | None) -> int:
        if isinstance(c.source, int):
            if c.source >= self.width:
                raise ImportProblem(
                    f"{self.path}: column {c.source} for {c.name} does not exist "
                    f"({self.width} columns, counted from 0)"
                )
            return c.source
        if names is None:
            raise ImportProblem(
                f"{self.path}: column {c.source!r} for {c.name}: the file has no header "
                "(--no-header): give the column's index"
            )
        found = [j for j, n in enumerate(names) if n == c.source] or [
            j for j, n in enumerate(names) if n.strip() == c.source.strip()
        ]
        if len(found) > 1:
            raise ImportProblem(
                f"{self.path}: column {c.source!r} for {c.name} is in the header {len(found)} "
                f"times (columns {', '.join(map(str, found[:5]))}): give its index"
            )
        if not found:
            shown = ", ".join(names[:12]) + (
                f", … ({len(names)} columns)" if len(names) > 12 else ""
            )
            hint = f" (separator {self.sep!r}: --sep if it is another)" if len(names) == 1 else ""
            raise ImportProblem(
                f"{self.path}: no column {c.source!r} for {c.name} (columns: {shown}){hint}"
            )
        return found[0]

    def chunks(self, progress: bool = False) -> Iterator[tuple[int, dict[str, np.ndarray]]]:
        """(first data row, {name: the column's values as float64, NaN where empty}), in chunks
        of the requested columns only."""
        import pandas as pd

        wanted = sorted(set(self.positions.values()))
        size, start, next_log = max(self.path.stat().st_size, 1), 0, PROGRESS_STEP
        with open(self.path, "rb") as handle:
            try:
                reader = pd.read_csv(
                    handle,
                    sep=self.sep,
                    header=None,
                    names=list(range(self.width)),
                    usecols=wanted,
                    index_col=False,
                    skiprows=self.skip,
                    chunksize=self.chunk_rows,
                    skipinitialspace=self.sep != " ",
                    encoding=self.encoding,
                    engine="c",
                )
                for chunk in reader:
                    yield (
                        start,
                        {
                            name: self._numbers(chunk[j], name, start)
                            for name, j in self.positions.items()
                        },
                    )
                    start += len(chunk)
                    if progress and handle.tell() / size >= next_log:
                        LOG.info("%s: %3.0f %% checked", self.path, 100 * handle.tell() / size)
                        next_log = (
                            math.floor(handle.tell() / size / PROGRESS_STEP + 1) * PROGRESS_STEP
                        )
            except ImportProblem:
                raise
            except (ValueError, UnicodeDecodeError, OverflowError, csv.Error) as err:
                # pandas' ParserError and EmptyDataError are ValueErrors
                raise self._unreadable(err) from None

    def _numbers(self, series, name: str, start: int) -> np.ndarray:
        import pandas as pd
        from pandas.api.types import is_bool_dtype, is_numeric_dtype

        if is_numeric_dtype(series.dtype) and not is_bool_dtype(series.dtype):
            return series.to_numpy(dtype=np.float64)
        if is_bool_dtype(series.dtype):
            bad = series.notna()
            values = None
        else:
            values = pd.to_numeric(series, errors="coerce")
            text = series.astype(str).str.strip()
            bad = values.isna() & series.notna() & (text != "")
            if is_bool_dtype(values.dtype):
                bad = series.notna()
        if bad.any():
            k = int(np.argmax(bad.to_numpy()))
            cell = str(series.iloc[k])
            comma = re.fullmatch(r"\s*[-+]?\d*,\d+\s*", cell)
            raise ImportProblem(
                f"{self.path}: {self.labels[name]} holds {cell!r} at data row "
                f"{start + k + 1}, not a number"
                + (" (a decimal comma: export with '.')" if comma else "")
            )
        return values.to_numpy(dtype=np.float64)


class _MatSource:
    """The requested variables of a MATLAB file (v4–v7), loaded whole by scipy, as float64."""

    kind = "MATLAB"

    def __init__(self, path: Path, columns: Sequence[Column]):
        self.path = path
        self.labels = {
            c.name: f"variable {c.source!r}" + ("" if c.name == "time" else f" ({c.name})")
            for c in columns
        }
        self.data = read_mat(path, columns)
        lengths = {name: len(v) for name, v in self.data.items()}
        if len(set(lengths.values())) != 1:
            raise ImportProblem(
                f"{path}: the variables differ in length ("
                + ", ".join(f"{self.labels[k]}: {n}" for k, n in lengths.items())
                + ")"
            )
        if 0 in lengths.values():
            raise ImportProblem(f"{path}: no data (the variables are empty)")

    def chunks(self, progress: bool = False) -> Iterator[tuple[int, dict[str, np.ndarray]]]:
        n = len(next(iter(self.data.values())))
        for start in range(0, n, CSV_CHUNK_ROWS):
            yield start, {k: v[start : start + CSV_CHUNK_ROWS] for k, v in self.data.items()}


def read_mat(path: Path, columns: Sequence[Column]) -> dict[str, np.ndarray]:
    """The variables of a MATLAB file (v4–v7) as float64 vectors."""
    from scipy.io import loadmat

    try:
        doc = loadmat(path, squeeze_me=True, struct_as_record=False)
    except NotImplementedError:
        raise ImportProblem(
            f"{path}: a MATLAB v7.3 (HDF5) file: save it with save(..., '-v7') or export "
            "CSV (v7.3 would need h5py, not a dependency)"
        ) from None
    except Exception as err:  # noqa: BLE001 - scipy's readers raise whatever a damaged file gives
        raise ImportProblem(
            f"{path}: not a readable MATLAB file ({type(err).__name__}: "
            f"{' '.join(str(err).split())[:200]})"
        ) from None
    return {c.name: _mat_variable(path, doc, str(c.source)) for c in columns}


def _mat_variable(path: Path, doc: Mapping[str, Any], where: str) -> np.ndarray:
    node: Any = doc
    for token in where.split("."):
        match = re.fullmatch(r"([^\[\]]+)(?:\[(\d+)\])?", token)
        name, index = match.groups() if match else (None, None)
        value = (
            (node.get(name) if isinstance(node, Mapping) else getattr(node, name, None))
            if name
            else None
        )
        if value is None:
            raise ImportProblem(f"{path}: no variable {where!r} (at {token!r})")
        if index is not None:
            value = np.asarray(value)
            k = int(index)
            if value.ndim == 2 and k < value.shape[1]:
                value = value[:, k]
            elif value.ndim == 1 and k < value.shape[0] and value.dtype == object:
                value = value[k]
            else:
                raise ImportProblem(
                    f"{path}: {where!r}: index {k} is out of range (shape {value.shape})"
                )
        node = value
    raw = np.asarray(node)
    if np.iscomplexobj(raw):
        raise ImportProblem(
            f"{path}: variable {where} is complex: save its real part, abs() or angle() instead"
        )
    if raw.dtype == bool:
        raise ImportProblem(f"{path}: variable {where} is logical (true/false), not numbers")
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error")  # numpy's ComplexWarning: an object array of complex
            values = np.asarray(node, dtype=np.float64)
    except (TypeError, ValueError, Warning):
        kind = "complex" if any(isinstance(v, complex) for v in raw.ravel()[:1000]) else "numeric"
        if kind == "complex":
            raise ImportProblem(
                f"{path}: variable {where} is complex: save its real part, abs() or angle() instead"
            ) from None
        raise ImportProblem(f"{path}: {where!r} is not numeric") from None
    if values.ndim != 1:
        raise ImportProblem(
            f"{path}: {where!r} has shape {values.shape}: name one column, e.g. {where}[0]"
            if values.ndim
            else f"{path}: {where!r} is a single value, not a series"
        )
    return values


# -- the first pass: what the columns hold -------------------------------------------------------


@dataclass
class _ChannelSummary:
    """A channel's cells: how many, missing, overloaded; the finite ones' span [contract unit];
    how many fall outside a range known before the pass."""

    label: str
    factor: float
    known: tuple[float, float] | None
    n: int = 0
    missing: int = 0
    overload: int = 0
    first_overload: tuple[int, float] | None = None
    lo: float = math.inf
    hi: float = -math.inf
    outside: int = 0

    def add(self, start: int, raw: np.ndarray) -> None:
        self.n += len(raw)
        nan = np.isnan(raw)
        over = ~nan & ~(np.abs(raw) < OVERLOAD)
        self.missing += int(np.count_nonzero(nan))
        count = int(np.count_nonzero(over))
        if count and self.first_overload is None:
            k = int(np.argmax(over))
            self.first_overload = (start + k + 1, float(raw[k]))
        self.overload += count
        good = raw[~(nan | over)] * self.factor
        if good.size:
            self.lo, self.hi = min(self.lo, float(good.min())), max(self.hi, float(good.max()))
            if self.known:
                self.outside += int(
                    np.count_nonzero((good < self.known[0]) | (good > self.known[1]))
                )

    @property
    def valid(self) -> int:
        return self.n - self.missing - self.overload


@dataclass
class _LineFit:
    """Least squares of y (time from the first sample) over x (the sample index), merged chunk by
    chunk (Chan et al.'s pairwise update: no sum of squares of large numbers)."""

    n: int = 0
    mx: float = 0.0
    my: float = 0.0
    sxx: float = 0.0
    sxy: float = 0.0

    def add(self, x: np.ndarray, y: np.ndarray) -> None:
        m = len(x)
        if not m:
            return
        mx, my = float(x.mean()), float(y.mean())
        dx = x - mx
        sxx, sxy = float(dx @ dx), float(dx @ (y - my))
        n = self.n + m
        ex, ey = mx - self.mx, my - self.my
        self.sxx += sxx + ex * ex * self.n * m / n
        self.sxy += sxy + ex * ey * self.n * m / n
        self.mx += ex * m / n
        self.my += ey * m / n
        self.n = n

    @property
    def slope(self) -> float:
        return self.sxy / self.sxx if self.sxx > 0 else math.nan

    @property
    def intercept(self) -> float:
        return self.my - self.slope * self.mx


@dataclass
class _Summary:
    """The first pass over a source: rows, each channel's summary, the time axis' line."""

    rows: int = 0
    channels: dict[str, _ChannelSummary] = field(default_factory=dict)
    t0: float | None = None
    fit: _LineFit = field(default_factory=_LineFit)


def _time_values(source, label: str, start: int, raw: np.ndarray, factor: float) -> np.ndarray:
    """The time column's values in s; every one finite, or one line naming the first that is
    not."""
    bad = ~(np.abs(raw) < OVERLOAD)
    if bad.any():
        k = int(np.argmax(bad))
        what = "empty" if np.isnan(raw[k]) else f"{raw[k]:g}"
        raise ImportProblem(
            f"{source.path}: the time {label} is {what} at data row {start + k + 1}: "
            "every sample needs its time (or leave --time out and give --fs)"
        )
    return raw * factor


def _first_pass(source, req: Request, known: Mapping[str, tuple[float, float] | None]) -> _Summary:
    summary = _Summary(
        channels={
            c.name: _ChannelSummary(source.labels[c.name], c.factor, known.get(c.name))
            for c in req.channels
        }
    )
    for start, chunk in source.chunks(progress=True):
        for c in req.channels:
            summary.channels[c.name].add(start, chunk[c.name])
        if req.time is not None:
            t = _time_values(source, source.labels["time"], start, chunk["time"], req.time.factor)
            if summary.t0 is None and len(t):
                summary.t0 = float(t[0])
            summary.fit.add(np.arange(start, start + len(t), dtype=np.float64), t - summary.t0)
        summary.rows = start + len(next(iter(chunk.values())))
    return summary


def _judge_channels(source, summary: _Summary) -> list[str]:
    """Refuse a channel without a single value, or overloaded beyond CLIP_LIMIT; notes for the
    overloads stored as missing."""
    notes = []
    for name, s in summary.channels.items():
        if s.valid == 0:
            raise ImportProblem(
                f"{source.path}: {s.label} holds no value to import: of its {s.n} cells "
                f"{s.missing} are empty or NaN and {s.overload} are overloads (|v| ≥ {OVERLOAD:g}"
                " or ±inf)"
            )
        if s.overload > CLIP_LIMIT * s.n:
            row, value = s.first_overload
            raise ImportProblem(
                f"{source.path}: {s.label} is overloaded in {100 * s.overload / s.n:.3g} % of "
                f"its {s.n} samples (more than {100 * CLIP_LIMIT:g} %; |v| ≥ {OVERLOAD:g} or "
                f"±inf, first {value:g} at data row {row}): the DAQ's sentinel for a saturated "
                "input, too many to store as missing"
            )
        if s.overload:
            row, value = s.first_overload
            notes.append(
                f"{name}: {s.overload} overload value(s) (|v| ≥ {OVERLOAD:g} or ±inf, first "
                f"{value:g} at data row {row}) stored as missing"
            )
    return notes


def _judge_time(source, req: Request, summary: _Summary) -> tuple[float, str]:
    """fs [Hz] from the slope of the least-squares line through the time column (or as given),
    and a note when the time axis did not start at 0. The residuals are checked in the second
    pass, before each chunk is written."""
    if req.time is None:
        return float(req.fs), ""
    if summary.rows < 2:
        raise ImportProblem(f"{source.path}: the time column needs at least two values")
    slope = summary.fit.slope
    if not (math.isfinite(slope) and slope > 0):
        raise ImportProblem(f"{source.path}: the time column does not increase")
    fitted = float(f"{1 / slope:.9g}")  # 1/Δt's rounding noise off
    if req.fs is not None and not math.isclose(fitted, req.fs, rel_tol=1e-3):
        raise ImportProblem(
            f"{source.path}: the time column gives fs = {fitted:g} Hz, --fs says {req.fs:g} Hz"
        )
    note = (
        f"time axis started at {summary.t0:.9g} s in the source; shifted to 0"
        if summary.t0 != 0
        else ""
    )
    return (float(req.fs) if req.fs is not None else fitted), note


def _check_time_residuals(source, summary: _Summary, start: int, t: np.ndarray) -> None:
    fit = summary.fit
    k = np.arange(start, start + len(t), dtype=np.float64)
    off = np.abs(t - summary.t0 - (fit.intercept + fit.slope * k))
    if off.max(initial=0.0) > TIME_TOLERANCE * fit.slope:
        i = int(np.argmax(off))
        expected = summary.t0 + fit.intercept + fit.slope * k[i]
        raise ImportProblem(
            f"{source.path}: the time column is not sampled at a fixed rate: sample "
            f"{start + i} is at {t[i]:.9g} s, {off[i] / fit.slope:.2g} samples from "
            f"{expected:.9g} s on the least-squares line (fs = {1 / fit.slope:g} Hz; "
            f"{TIME_TOLERANCE:g} sample allowed): a gap or a restart: split the file, or "
            "export at a fixed rate"
        )


def derived_range(lo: float, hi: float) -> tuple[float, float]:
    """An ADC range for data spanning [lo, hi] without one: the span with RANGE_MARGIN free on
    each side, rounded outward to three significant digits."""
    span = max(hi - lo, MIN_RELATIVE_SPAN * max(abs(lo), abs(hi)), 1e-15)
    lo, hi = lo - RANGE_MARGIN * span, hi + RANGE_MARGIN * span
    e = math.floor(math.log10(hi - lo)) - 2
    return float(f"{math.floor(lo / 10.0**e)}e{e}"), float(
        f"{math.ceil(hi / 10.0**e)}e{e}"
    )  # exact decimals


# -- the import ----------------------------------------------------------------------------------


@dataclass(frozen=True)
class Request:
    """One import: the source file and how to read it, where the capture goes."""

    source: Path
    dataset: str
    experiment: str
    channels: tuple[Column, ...]
    time: Column | None = None
    fs: float | None = None
    ranges: Mapping[str, tuple[float, float]] | None = None
    attrs: Mapping[str, Any] | None = None
    sep: str | None = None
    header: bool = True
    model: str | None = None
    raw_dir: Path = Path("raw")
    lock_timeout: float = LOCK_TIMEOUT_S


def _check_request(req: Request) -> None:
    """Everything that needs no file: names, fs, channels, ranges, attributes."""
    check_dataset_name(req.dataset, "--dataset")
    check_experiment_name(req.experiment, "--experiment")
    for option, name in (("--dataset", req.dataset), ("--experiment", req.experiment)):
        if len(name) > MAX_NAME:
            raise ImportProblem(
                f"{option}: a name of {len(name)} characters: at most {MAX_NAME} (it becomes a "
                "file name)"
            )
    if req.fs is not None and not (isinstance(req.fs, (int, float)) and 0 < req.fs < math.inf):
        raise ImportProblem(f"--fs {req.fs}: the sampling rate must be a finite number > 0 Hz")
    if req.time is None and req.fs is None:
        raise ImportProblem(
            f"{req.source}: give the time column (--time) or the sampling rate (--fs)"
        )
    if not req.channels or len({c.name for c in req.channels}) != len(req.channels):
        raise ImportProblem(f"{req.source}: name each channel once (--channel)")
    slow = [c.name for c in req.channels if c.name in SLOW_CHANNELS]
    if slow:  # they run at their own rate on their own time axis (the contract's time_slow)
        raise ImportProblem(
            f"{req.source}: {slow[0]} is a slow (thermometer) channel, which the import "
            "does not take yet; leave it out"
        )
    for channel, given in (req.ranges or {}).items():
        lo, hi = (float(v) for v in given)
        if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
            raise ImportProblem(f"--range {channel}={lo:g},{hi:g}: finite LOW < HIGH")
    for key, value in (req.attrs or {}).items():
        if key in OWN_ATTRS:
            raise ImportProblem(f"--attr {key}: set by the import itself")
        if isinstance(value, float) and not math.isfinite(value):
            raise ImportProblem(f"--attr {key}={value}: not a finite number")


def run_import(req: Request) -> tuple[Path, Path]:
    """Write the capture and the manifest of one import; returns their paths. Every refusal is
    an ImportProblem (a file system error too: one line naming the file)."""
    try:
        return _run_import(req)
    except OSError as err:
        where = err.filename or req.source
        if err.errno == errno.ENAMETOOLONG:
            raise ImportProblem(f"{where}: file name too long") from None
        raise ImportProblem(f"{where}: {err.strerror or err}") from None


def _run_import(req: Request) -> tuple[Path, Path]:
    folder = Path(req.raw_dir) / req.dataset
    manifest_path, capture_path = folder / "dataset.yaml", folder / f"{req.experiment}.nc"
    _check_request(req)
    if capture_path.exists():
        raise _exists(capture_path)
    if not req.source.is_file():
        raise ImportProblem(
            f"{req.source}: {'not a file' if req.source.exists() else 'no such file'}"
        )
    columns = [*req.channels, *([req.time] if req.time else [])]
    source = (
        _MatSource(req.source, columns)
        if req.source.suffix.lower() == ".mat"
        else _CsvSource(req.source, columns, req.sep, req.header)
    )
    before = req.source.stat()
    with dataset_lock(folder, req.lock_timeout):
        if capture_path.exists():  # made by an import that held the lock before us
            raise _exists(capture_path)
        manifest = _existing_manifest(manifest_path, req)
        known = _known_ranges(manifest, manifest_path, req)
        if manifest is not None and req.fs is not None:
            _check_fs(manifest, manifest_path, req, req.fs)
        summary = _first_pass(source, req, known)
        if summary.rows < MIN_SAMPLES:
            raise ImportProblem(
                f"{req.source}: {summary.rows} data row: a capture needs at least {MIN_SAMPLES} "
                "samples"
            )
        notes = _judge_channels(source, summary)
        fs, time_note = _judge_time(source, req, summary)
        if manifest is not None:
            _check_fs(manifest, manifest_path, req, fs)
        ranges = {
            c: known[c] or derived_range(summary.channels[c].lo, summary.channels[c].hi)
            for c in summary.channels
        }
        for channel, s in summary.channels.items():
            problem = clipping_problem(channel, s.outside, s.n, *ranges[channel], manifest_path)
            if problem:
                raise ImportProblem(f"{req.source}: {problem}")
        doc = _manifest_document(manifest, manifest_path, req, fs, ranges)
        note = "; ".join(filter(None, [time_note, *notes]))
        attrs = {
            "dataset": req.dataset,
            "experiment": req.experiment,
            "fs": fs,
            "source": "measured",
            "software_version": __version__,
            "imported_from": req.source.name,
            **({"import_note": note} if note else {}),
            **dict(req.attrs or {}),
        }
        _write_capture(source, req, summary, capture_path, attrs, ranges, before)
        try:
            with atomic_path(manifest_path) as tmp:
                tmp.write_text(yaml.safe_dump(doc, sort_keys=False, allow_unicode=True))
        except BaseException:
            capture_path.unlink(missing_ok=True)  # a capture its manifest does not list: none
            raise
    for line in (time_note, *notes):
        if line:
            LOG.warning("%s: %s", req.source, line)
    return capture_path, manifest_path


def _exists(capture_path: Path) -> ImportProblem:
    return ImportProblem(
        f"{capture_path} exists: measured captures are never overwritten "
        "(remove it to import again)"
    )


def _write_capture(
    source,
    req: Request,
    summary: _Summary,
    capture_path: Path,
    attrs: Mapping[str, Any],
    ranges: Mapping[str, tuple[float, float]],
    before: os.stat_result,
) -> None:
    """The second pass: each chunk (time checked against the line, overloads to NaN, units
    converted) into a hidden temporary, read back by CaptureWriter, then linked to its name if no
    file has it."""
    specs = [channel_spec(c, *ranges[c]) for c in summary.channels]
    factors = {c.name: c.factor for c in req.channels}
    tmp = temporary_path(capture_path, hidden=True)
    try:
        rows = 0
        try:
            with CaptureWriter(tmp, attrs, specs, summary.rows) as writer:
                for start, chunk in source.chunks():
                    if req.time is not None:
                        _check_time_residuals(
                            source, summary, start, chunk["time"] * req.time.factor
                        )
                    n = len(next(iter(chunk.values())))
                    if start + n > summary.rows:
                        raise _changed(req.source)
                    writer.write(
                        {
                            c: np.where(np.abs(chunk[c]) < OVERLOAD, chunk[c], np.nan) * factors[c]
                            for c in summary.channels
                        }
                    )
                    rows = start + n
                after = req.source.stat()
                if rows != summary.rows or (after.st_size, after.st_mtime_ns) != (
                    before.st_size,
                    before.st_mtime_ns,
                ):
                    raise _changed(req.source)
        except ValueError as err:  # CaptureError and the writer's own: name the capture
            if isinstance(err, ImportProblem):
                raise
            raise ImportProblem(str(err).replace(str(tmp), str(capture_path))) from None
        try:  # the contract's own checks on open (packing bounds, the folding plan of --attr)
            open_capture(tmp).close()
        except CaptureError as err:
            problem = str(err).replace(str(tmp), str(capture_path))
            raise ImportProblem(
                f"{req.source}: the capture would break the contract: {problem}"
            ) from None
        _link(tmp, capture_path)
    finally:
        tmp.unlink(missing_ok=True)


def _changed(source: Path) -> ImportProblem:
    return ImportProblem(f"{source}: changed while it was imported: import it again when complete")


def _link(tmp: Path, path: Path) -> None:
    """``tmp`` under the name ``path`` only if no file has it (a hard link fails on an existing
    name, where a rename would replace it); where the file system has no hard links, a rename
    after a check, safe under the dataset's lock."""
    try:
        os.link(tmp, path)
    except FileExistsError:
        raise _exists(path) from None
    except OSError as err:
        if err.errno not in (errno.EPERM, errno.ENOTSUP, errno.EOPNOTSUPP, errno.EMLINK):
            raise
        if path.exists():
            raise _exists(path) from None
        os.replace(tmp, path)


def _existing_manifest(path: Path, req: Request) -> dict | None:
    """The dataset's manifest if it has one (a measured dataset without this experiment)."""
    if not path.exists():
        return None
    manifest = load_dataset(path.parent.parent, path.parent.name)
    if manifest["source"] != "measured":
        raise ImportProblem(
            f"{path}: source is {manifest['source']}: import into a measured dataset"
        )
    if req.experiment in manifest.get("experiments", []):
        raise ImportProblem(
            f"{path}: experiment {req.experiment} is listed already, without its capture"
        )
    return manifest


def _known_ranges(
    manifest: Mapping[str, Any] | None, path: Path, req: Request
) -> dict[str, tuple[float, float] | None]:
    """Each channel's range before the data are read: --range or the manifest's (they must
    agree), None where it is derived from the data."""
    have = manifest["daq"]["ranges"] if manifest else {}
    known: dict[str, tuple[float, float] | None] = {}
    for c in req.channels:
        given = (req.ranges or {}).get(c.name)
        if c.name in have and given and tuple(given) != tuple(have[c.name]):
            raise ImportProblem(
                f"--range {c.name}={given[0]:g},{given[1]:g} differs from daq.ranges.{c.name} "
                f"= {have[c.name]} in {path}"
            )
        value = have.get(c.name) or given
        known[c.name] = (float(value[0]), float(value[1])) if value else None
    return known


def _check_fs(manifest: Mapping[str, Any], path: Path, req: Request, fs: float) -> None:
    if not math.isclose(manifest["daq"]["fs"], fs, rel_tol=1e-6):
        raise ImportProblem(
            f"{req.source}: fs = {fs:g} Hz, {path} declares daq.fs = {manifest['daq']['fs']:g} Hz"
        )


def _manifest_document(
    manifest: Mapping[str, Any] | None,
    path: Path,
    req: Request,
    fs: float,
    ranges: Mapping[str, tuple[float, float]],
) -> dict:
    """The dataset's manifest with this import in it (scaffolded, or the existing one updated: a
    channel it already has keeps its range), validated: nothing invalid is written."""
    if manifest is None:
        manifest = {
            "name": req.dataset,
            "description": f"Imported from {req.source.name} by selfsense import: "
            "describe the actuator here.",
            "source": "measured",
            **({"model": req.model} if req.model else {}),
            "daq": {"fs": fs, "channels": [], "ranges": {}},
            "protocols": [],
            "experiments": [],
        }
    manifest = dict(manifest)
    daq = manifest["daq"]
    for channel, (lo, hi) in ranges.items():
        daq["ranges"].setdefault(channel, [lo, hi])
        if channel not in daq["channels"]:
            daq["channels"].append(channel)
    manifest["experiments"] = [*manifest.get("experiments", []), req.experiment]
    doc = yaml.safe_load(yaml.safe_dump(manifest, sort_keys=False))  # as a reader will see it
    try:
        validate_document(doc, "dataset.schema.yaml", path)
    except ManifestError as err:
        raise ImportProblem(str(err)) from None
    return doc


# -- one import into a dataset at a time -----------------------------------------------------------


@contextmanager
def dataset_lock(folder: Path, timeout: float = LOCK_TIMEOUT_S) -> Iterator[None]:
    """Hold ``folder/.import.lock`` (``fcntl.flock``, exclusive), waiting up to ``timeout`` s.

    The folder is made if need be, and removed again on leaving if this import made it and left
    it empty (a failed import into a new dataset). The lock file is removed while it is held:
    an import waiting on it then finds, once it has the lock, that the name no longer leads to
    the file it holds, and takes the lock again on the new file (so two never hold it at once).
    A killed import's lock is released by the kernel with its process.
    """
    path = folder / LOCK_NAME
    made: list[Path] = []
    deadline = time.monotonic() + timeout
    while True:
        made += _make_folders(folder)
        try:
            fd = os.open(path, os.O_RDWR | os.O_CREAT | os.O_CLOEXEC, 0o644)
        except FileNotFoundError:  # another import removed the folder it had made: again
            continue
        try:
            while True:
                try:
                    fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
                    break
                except BlockingIOError:
                    if time.monotonic() > deadline:
                        raise ImportProblem(
                            f"{path}: another import into dataset {folder.name} still runs "
                            f"after {timeout:g} s: try again when it has finished"
                        ) from None
                    time.sleep(0.05)
            try:
                held, named = os.fstat(fd), os.stat(path)
                current = (held.st_dev, held.st_ino) == (named.st_dev, named.st_ino)
            except FileNotFoundError:
                current = False
        except BaseException:
            os.close(fd)
            raise
        if current:
            break
        os.close(fd)  # the lock file was removed by the import before us: take the new one
    try:
        yield
    finally:
        path.unlink(missing_ok=True)
        for made_folder in reversed(made):
            try:
                made_folder.rmdir()  # only if empty: this import failed into a new dataset
            except OSError:
                break
        os.close(fd)


def _make_folders(folder: Path) -> list[Path]:
    """Make ``folder`` and its missing parents; the ones made, outermost first."""
    missing = []
    for parent in [folder, *folder.parents]:
        if parent.exists():
            break
        missing.append(parent)
    made = []
    for parent in reversed(missing):
        try:
            parent.mkdir()
            made.append(parent)
        except FileExistsError:
            pass
    return made
