"""The import's reader of CSV/TSV files: the separator, the layout, the columns in chunks.

Columns go by header name or by position counted from 1, as people count them (a header name made
of digits is typed with '#'). The separator is the one given (``--sep``), a tab for ``.tsv`` and
``.tab`` files, or detected among tab, semicolon and comma from the first lines (the one that
splits them alike; logged where it is not a ``.csv`` file's comma). The encoding is UTF-8 (a
byte-order mark skipped), else Latin-1 (a header written on Windows).

The file's layout is judged when it is opened: the header's field count against the first data
rows' and the last one's (rows that end in the separator keep their columns; any other difference
is refused, naming the row), and every requested column located, so that nothing shifts. The
columns are then read by pandas in chunks, only the requested ones, each cell a number or empty (a
decimal comma or a text is refused, naming the cell's row): memory does not grow with the file's
length, and the import reads the file twice (a first pass that checks and sums up, a second that
streams into the capture).
"""

from __future__ import annotations

import codecs
import csv
import logging
import math
import os
import re
import shlex
from collections import Counter
from collections.abc import Iterator, Sequence
from pathlib import Path

import numpy as np

from selfsense.io.sources import (
    CHUNK_ROWS,
    Column,
    ImportProblem,
    column_spans,
    listed,
    one_column_each,
    source_labels,
)

#: the import's log (``selfsense import`` shows it): the separator detected, a column named
#: like another's position
LOG = logging.getLogger("selfsense.io.importer")

#: cells a CSV chunk holds (rows × fields: the tokenizer keeps every field of a chunk's rows, also
#: the ones not read), in at most CHUNK_ROWS rows
CSV_CHUNK_CELLS = 1 << 22
#: data rows whose field count is compared with the header's, besides the last
CHECKED_ROWS = 10
#: the separators detected without --sep, in order of preference when several split the first
#: lines alike (a decimal comma splits a semicolon file's rows alike too: ';' wins)
DETECTED_SEPARATORS = ("\t", ";", ",")
#: non-blank lines the separator is detected from
DETECTION_LINES = 10
#: the first pass logs how far it has come at each this fraction of the file
PROGRESS_STEP = 0.1


def parse_separator(text: str) -> str:
    """One character that cannot be part of a number; ``\\t`` as typed in a shell, or ``tab``,
    is a tab."""
    sep = "\t" if text in ("\\t", "tab") else text
    if not (
        len(sep) == 1
        and (sep == "\t" or sep.isprintable())
        and not sep.isalnum()
        and sep not in '.+-"'
    ):
        raise ImportProblem(
            f"--sep {text!r}: one character that cannot be part of a number "
            "(',', ';', '|', ' ' or tab)"
        )
    return sep


def typed_separator(sep: str) -> str:
    """The --sep argument that gives ``sep``, as a shell takes it: tab, ',', '|', ' '."""
    return "tab" if sep == "\t" else shlex.quote(sep) if sep == "'" else f"'{sep}'"


def _fields(line: str, sep: str) -> int:
    """How many fields ``line`` has split at ``sep`` (quotes respected), one empty field at the
    end not counted (a row that ends in the separator)."""
    try:
        row = next(csv.reader([line], delimiter=sep, skipinitialspace=sep != " "), [])
    except csv.Error:  # a field beyond csv's limit (128 KiB): no number, so sep does not split
        return 1
    if len(row) > 1 and row[-1].strip() == "":
        row = row[:-1]
    return len(row)


def splitting(lines: Sequence[str], candidates: Sequence[str] = DETECTED_SEPARATORS) -> list[str]:
    """The candidates that split every line into one number ≥ 2 of fields, preferred first."""
    return [
        sep
        for sep in candidates
        if len({_fields(line, sep) for line in lines}) == 1 and _fields(lines[0], sep) >= 2
    ]


def detect_separator(path: Path, lines: Sequence[str]) -> str:
    """The separator of a file given without --sep, from its first non-blank lines: the
    preferred of tab, ';' and ',' that splits them alike; else the preferred one that splits each
    into two fields at least (the layout check then names the row that differs); a file that none
    splits is one column, unless a character common to all lines suggests its separator."""
    if not lines:
        return ","
    alike = splitting(lines)
    if alike:
        return alike[0]
    below = splitting(lines[1:]) if len(lines) > 2 else []
    if below:  # a title or comment line above the table: the layout check names it
        return below[0]
    ragged = [s for s in DETECTED_SEPARATORS if all(_fields(line, s) >= 2 for line in lines)]
    if ragged:
        return ragged[0]
    common = set(lines[0].strip())
    for line in lines[1:]:
        common &= set(line.strip())
    counts = Counter(
        ch
        for line in lines
        for ch in line.strip()
        if ch in common and not ch.isalnum() and ch not in ".+-\"'"
    )
    if counts:
        likely = counts.most_common(1)[0][0]
        raise ImportProblem(
            f"{path}: no comma, semicolon or tab splits its rows alike: give --sep, e.g. "
            f"--sep {typed_separator(likely)}"
        )
    return ","  # one column of numbers


class CsvSource:
    """The requested columns of a CSV/TSV file, located by its header and read in chunks.

    The header's field count is compared with the first CHECKED_ROWS data rows' and the last
    one's: data rows that end in one more, empty field (a separator at the end of every data row,
    the header without it) keep their columns; any other difference is refused. Columns are read
    by position, so nothing shifts."""

    rows = "rows"
    declared_fs = None  # a CSV has no clock of its own
    note = ""

    def __init__(self, path: Path, columns: Sequence[Column], sep: str | None, header: bool):
        self.path, self.header = path, header
        self.encoding = self._encoding(path)
        self.detected = not sep and path.suffix.lower() not in (".tsv", ".tab")
        if sep:
            self.sep = parse_separator(sep)
        elif not self.detected:
            self.sep = "\t"
        else:
            self.sep = detect_separator(path, self._first_lines())
            if self.sep != "," or path.suffix.lower() != ".csv":
                LOG.info(
                    "%s: separator %s detected (--sep to choose another)",
                    path,
                    typed_separator(self.sep),
                )
        self.kind = "TSV" if self.sep == "\t" else "CSV"
        self.names, self.width, self.skip = self._layout()
        self.positions = {c.name: self._position(c, self.names) for c in columns}
        self.labels = source_labels(
            columns,
            lambda c: f"column {c.spelled if isinstance(c.source, int) else repr(c.source)}",
        )
        one_column_each(path, self.labels, self.positions)
        self.chunk_rows = int(min(CHUNK_ROWS, max(64, CSV_CHUNK_CELLS // self.width)))

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

    def _first_lines(self) -> list[str]:
        """The file's first DETECTION_LINES non-blank lines (a line as long as it is: a wide
        file's header may be megabytes)."""
        lines = []
        with open(self.path, newline="", encoding=self.encoding, errors="replace") as text:
            for line in text:
                if line.strip():
                    lines.append(line.rstrip("\r\n"))
                    if len(lines) >= DETECTION_LINES:
                        break
        return lines

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
        if width == 1 and not self.detected:
            self._one_field()
        if last is not None and len(rows) == CHECKED_ROWS:
            rows.append(("the last", last))
        first, after = (names, rows) if names is not None else (rows[0][1], rows[1:])
        below = {len(row) for _, row in after}
        if len(first) == 1 and len(below) == 1 and min(below) >= 2:
            raise ImportProblem(
                f"{self.path}: its first line ({first[0].strip()[:40]!r}) is one field, the "
                f"lines after it split into {min(below)} at {self.sep!r}: a title or comment "
                "above the table: remove the lines above the "
                + ("header" if names is not None else "data")
            )
        trailing = False
        for k, row in rows:
            if len(row) == width + 1 and row[-1].strip() == "":
                trailing = True  # one more, empty field: the row ends in the separator
            elif k == "the last" and len(row) < width:
                raise ImportProblem(
                    f"{self.path}: the last data row has {len(row)} fields where the rows "
                    f"before it have {width}: the file ends inside a row, as an interrupted write "
                    "leaves it: remove its last line, or export the file again"
                )
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

    def _one_field(self) -> None:
        """A separator given (or the extension's) that leaves a row one field, where another
        splits the first lines alike: refused, naming the one to type."""
        lines = self._first_lines()
        others = (
            splitting(lines, [s for s in DETECTED_SEPARATORS if s != self.sep]) if lines else []
        )
        if others:
            raise ImportProblem(
                f"{self.path}: separator {typed_separator(self.sep)} leaves each row one field; "
                f"{typed_separator(others[0])} splits them into {_fields(lines[0], others[0])}: "
                f"type --sep {typed_separator(others[0])}"
            )

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
        """The column's index (from 0) in a row; positions are given counted from 1."""
        if isinstance(c.source, int):
            if c.source < 1:
                raise ImportProblem(
                    f"{self.path}: column {c.source} for {c.name}: columns are counted from 1 "
                    f"(type {Column(c.name, 1, c.unit).typed()} for the first)"
                )
            if c.source > self.width:
                raise ImportProblem(
                    f"{self.path}: column {c.source} for {c.name} does not exist (the file has "
                    f"{self.width} columns, counted from 1)"
                )
            named = [
                j + 1
                for j, n in enumerate(names or [])
                if n.strip() == str(c.source) and j + 1 != c.source
            ]
            if named:  # digits are positions: say which column that is, and how to name the other
                LOG.warning(
                    "%s: %s %s is the file's column %d; the header's column %d is named %r: "
                    "type %s for that one",
                    self.path,
                    "--time" if c.name == "time" else "--channel",
                    c.typed(),
                    c.source,
                    named[0],
                    str(c.source),
                    Column(c.name, str(c.source), c.unit).typed(),
                )
            return c.source - 1
        if names is None:
            raise ImportProblem(
                f"{self.path}: column {c.source!r} for {c.name}: the file has no header "
                "(--no-header): give the column's position, counted from 1"
            )
        found = [j for j, n in enumerate(names) if n == c.source] or [
            j for j, n in enumerate(names) if n.strip() == c.source.strip()
        ]
        if len(found) > 1:
            raise ImportProblem(
                f"{self.path}: column {c.source!r} for {c.name} is in the header {len(found)} "
                f"times (columns {', '.join(str(j + 1) for j in found[:5])}, counted from 1): "
                "give its position"
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

    def _read(self, usecols: Sequence[int] | None, progress: bool = False):
        """pandas' chunks of the columns at ``usecols`` (all if None), with the byte offset
        reached after each."""
        import pandas as pd

        size, next_log = max(self.path.stat().st_size, 1), PROGRESS_STEP
        with open(self.path, "rb") as handle:
            try:
                reader = pd.read_csv(
                    handle,
                    sep=self.sep,
                    header=None,
                    names=list(range(self.width)),
                    usecols=usecols,
                    index_col=False,
                    skiprows=self.skip,
                    chunksize=self.chunk_rows,
                    skipinitialspace=self.sep != " ",
                    encoding=self.encoding,
                    engine="c",  # a tab too: the python engine warns and is slow
                )
                for chunk in reader:
                    yield chunk
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

    def chunks(self, progress: bool = False) -> Iterator[tuple[int, dict[str, np.ndarray]]]:
        """(first data row, {name: the column's values as float64, NaN where empty}), in chunks
        of the requested columns only."""
        start = 0
        for chunk in self._read(sorted(set(self.positions.values())), progress):
            yield (
                start,
                {name: self._numbers(chunk[j], name, start) for name, j in self.positions.items()},
            )
            start += len(chunk)

    def varying(self, name: str) -> str:
        """For the refusal of a constant column: the columns of the file that vary (a second
        pass over all of them: an error path)."""
        import pandas as pd

        lo = np.full(self.width, np.inf)
        hi = np.full(self.width, -np.inf)
        for chunk in self._read(None):
            values = chunk.apply(pd.to_numeric, errors="coerce").to_numpy(dtype=np.float64)
            lo_chunk, hi_chunk = column_spans(values)
            lo, hi = np.fmin(lo, lo_chunk), np.fmax(hi, hi_chunk)
        skip = {self.positions.get("time"), self.positions[name]}
        vary = [
            f"{j + 1}" + (f" ({self.names[j].strip()})" if self.names else "")
            for j in range(self.width)
            if lo[j] < hi[j] and j not in skip
        ]
        if not vary:
            return "no other column of the file varies"
        return f"columns are counted from 1: the columns that vary are {listed(vary)}"

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
            if not self.header and start + k == 0 and int(bad.sum()) == 1:
                raise ImportProblem(
                    f"{self.path}: {self.labels[name]} holds {cell!r} in its first row and numbers "
                    "below it: the file has a header row: leave --no-header out"
                )
            raise ImportProblem(
                f"{self.path}: {self.labels[name]} holds {cell!r} at data row "
                f"{start + k + 1}, not a number"
                + (" (a decimal comma: export with '.')" if comma else "")
            )
        return values.to_numpy(dtype=np.float64)
