"""The import's readers of MATLAB ``.mat`` files: v4 to v7 (``scipy.io.loadmat``) and v7.3
(HDF5, ``h5py``).

Variables go by name, struct fields by ``.``, a column of a matrix or an element of a struct array
by ``[k]`` counted from 1 as MATLAB counts (``data[2]`` is MATLAB's ``data(:,2)``,
``rec.Y[1].Data`` a field of a struct array's first element). A v7.3 file is told by its content
(:func:`is_hdf5`: HDF5's signature after the 512-byte header), not its suffix. Each requested
variable is located and its type checked when the file is opened: a wrong name, a complex, logical
or text variable, a matrix where a column is meant, or variables of different lengths stop with
one line naming the file and the variable before a pass begins.

**v4–v7.** scipy loads the file whole (:class:`MatSource`); the chunks are slices of its vectors.

**v7.3.** Variables are HDF5 datasets, stored transposed (MATLAB's R×C matrix is a dataset of
shape (C, R)), a struct's fields the members of its group: ``rec.Y`` is the group ``rec``'s
dataset ``Y``, ``data[k]`` MATLAB's ``data(:,k)``, the dataset's row k − 1. :class:`Mat73Source`
reads them in chunks by h5py's slicing, as the CSV reader streams. Complex (a compound of real and
imag), logical and char variables are refused as they are in a v7 file; cell and struct arrays
(object references) are refused in one line: save with ``-v7``, or store the channels as
matrices. A variable declared longer than the samples written (a ``matfile`` preallocation whose
logging stopped) is refused: h5py would read its chunks never written as the fill value
(:func:`unwritten`).
"""

from __future__ import annotations

import re
import warnings
from collections.abc import Iterator, Mapping, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np

from selfsense.io.sources import (
    CHUNK_ROWS,
    Column,
    ImportProblem,
    column_spans,
    listed,
    one_column_each,
    one_length,
    short_error,
    source_labels,
)


def is_hdf5(path: Path) -> bool:
    """Whether the file is HDF5 (a MATLAB v7.3 file: its signature after the 512-byte header)."""
    import h5py

    try:
        return bool(h5py.is_hdf5(str(path)))
    except OSError:
        return False


def mat_tokens(path: Path, c: Column) -> list[tuple[str, int | None]]:
    """A .mat variable path, ``rec.Y[2].Data`` → [("rec", None), ("Y", 2), ("Data", None)]: the
    indices counted from 1, as MATLAB counts (``data[1]`` is MATLAB's ``data(:,1)``)."""
    if isinstance(c.source, int):
        raise ImportProblem(
            f"{path}: {c.name}: column {c.source}: a .mat file names its variables (type "
            f"{Column(c.name, f'data[{c.source}]', c.unit).typed()} for column {c.source} of a "
            "matrix data)"
        )
    tokens: list[tuple[str, int | None]] = []
    parts = c.source.split(".")
    for k, token in enumerate(parts):
        match = re.fullmatch(r"([^\[\]]+)(?:\[([0-9]+)\])?", token)
        if match is None:
            raise ImportProblem(
                f"{path}: {c.source!r}: expected NAME, NAME.FIELD or NAME[k] (k counted from 1)"
            )
        name, index = match.groups()
        if index is not None and int(index) == 0:
            fixed = ".".join([*parts[:k], f"{name}[1]", *parts[k + 1 :]])
            raise ImportProblem(
                f"{path}: {c.source!r}: MATLAB counts from 1: {name}[1] is MATLAB's {name}(:,1), "
                f"the first (type {Column(c.name, fixed, c.unit).typed()})"
            )
        tokens.append((name, None if index is None else int(index)))
    return tokens


# -- MATLAB v4–v7 (scipy) --------------------------------------------------------------------------


class MatSource:
    """The requested variables of a MATLAB file (v4–v7), loaded whole by scipy, as float64."""

    kind = "MATLAB"
    rows = "samples"
    declared_fs = None
    note = ""

    def __init__(self, path: Path, columns: Sequence[Column]):
        self.path = path
        self.labels = source_labels(columns, lambda c: f"variable {c.source!r}")
        self.columns = {c.name: c for c in columns}
        self.doc = _load_mat(path)
        self.data = {c.name: _mat_variable(path, self.doc, c) for c in columns}
        one_column_each(
            path, self.labels, {c.name: tuple(mat_tokens(path, c)) for c in columns}, "variable"
        )
        lengths = {name: len(v) for name, v in self.data.items()}
        if one_length(path, "variables", self.labels, lengths) == 0:
            raise ImportProblem(f"{path}: no data (the variables are empty)")

    def chunks(self, progress: bool = False) -> Iterator[tuple[int, dict[str, np.ndarray]]]:
        n = len(next(iter(self.data.values())))
        for start in range(0, n, CHUNK_ROWS):
            yield start, {k: v[start : start + CHUNK_ROWS] for k, v in self.data.items()}

    def varying(self, name: str) -> str:
        """For the refusal of a constant column of a matrix: its columns that vary."""
        c = self.columns[name]
        head, _, last = str(c.source).rpartition(".")
        match = re.fullmatch(r"(.+)\[[0-9]+\]", last)
        if match is None:
            return ""
        matrix = ".".join(filter(None, [head, match.group(1)]))
        try:
            values = np.asarray(_mat_node(self.path, self.doc, Column(name, matrix, c.unit)))
            values = values.astype(np.float64) if values.ndim == 2 else None
        except (ImportProblem, TypeError, ValueError):
            values = None
        if values is None:
            return ""
        return varying_columns(matrix, *column_spans(values))


def varying_columns(matrix: str, lo: np.ndarray, hi: np.ndarray) -> str:
    """'the columns of <matrix> that vary are <matrix>[2], …' from each column's least and
    largest finite value (NaN where it has none)."""
    vary = [f"{matrix}[{k + 1}]" for k in range(len(lo)) if lo[k] < hi[k]]
    if not vary:
        return f"no column of {matrix} varies"
    return f"the columns of {matrix} that vary are {listed(vary)} (counted from 1)"


def _load_mat(path: Path) -> Mapping[str, Any]:
    from scipy.io import loadmat

    try:
        return loadmat(path, squeeze_me=True, struct_as_record=False)
    except NotImplementedError:  # a v7.3 file without HDF5's signature where h5py looks for it
        raise ImportProblem(
            f"{path}: a MATLAB v7.3 file that is not readable HDF5: save it with "
            "save(..., '-v7') or export CSV"
        ) from None
    except Exception as err:  # noqa: BLE001 - scipy's readers raise whatever a damaged file gives
        raise ImportProblem(
            f"{path}: not a readable MATLAB file ({type(err).__name__}: "
            f"{' '.join(str(err).split())[:200]})"
        ) from None


def read_mat(path: Path, columns: Sequence[Column]) -> dict[str, np.ndarray]:
    """The variables of a MATLAB file (v4–v7) as float64 vectors."""
    doc = _load_mat(path)
    return {c.name: _mat_variable(path, doc, c) for c in columns}


def _mat_node(path: Path, doc: Mapping[str, Any], c: Column) -> Any:
    from scipy.io.matlab import mat_struct

    node: Any = doc
    tokens = mat_tokens(path, c)
    for k, (name, index) in enumerate(tokens):
        if k and not isinstance(node, mat_struct):  # getattr would find numpy's own (data.T)
            parent = tokens[k - 1][0]
            if isinstance(node, np.ndarray) and node.dtype == object:
                raise ImportProblem(
                    f"{path}: {c.source!r}: {parent} is a struct array of {node.size} elements: "
                    f"name one, e.g. {parent}[1].{name}"
                )
            raise ImportProblem(
                f"{path}: {c.source!r}: {parent} is not a struct (no field {name!r})"
            )
        value = getattr(node, name, None) if k else node.get(name)
        if value is None:
            raise ImportProblem(f"{path}: no variable {c.source!r} (at {name!r})")
        if index is not None:
            value = np.asarray(value)
            if value.ndim == 1 and value.dtype != object:
                raise ImportProblem(
                    f"{path}: {c.source!r}: {name} is a vector of {value.size} samples, not a "
                    f"matrix: name it without [{index}]"
                )
            if value.ndim == 2 and index <= value.shape[1]:
                value = value[:, index - 1]
            elif value.ndim == 1 and index <= value.shape[0] and value.dtype == object:
                value = value[index - 1]
            else:
                size = (
                    f"has {value.shape[0]} elements"
                    if value.ndim == 1
                    else f"is {'×'.join(map(str, value.shape)) or '1×1'}"
                )
                raise ImportProblem(
                    f"{path}: {c.source!r}: {name}[{index}] does not exist ({name} {size}; "
                    "counted from 1)"
                )
        node = value
    return node


def _mat_variable(path: Path, doc: Mapping[str, Any], c: Column) -> np.ndarray:
    node = _mat_node(path, doc, c)
    where = c.source
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
            f"{path}: {where!r} has shape {values.shape}: name one column, e.g. {where}[1] "
            f"(MATLAB's {where}(:,1))"
            if values.ndim
            else f"{path}: {where!r} is a single value, not a series"
        )
    return values


# -- MATLAB v7.3 (HDF5) ----------------------------------------------------------------------------


def unwritten(ds: Any, axis: int, at: int) -> tuple[int, int] | None:
    """The first stretch [start, stop) of samples along ``axis`` of an HDF5 dataset, at index
    ``at`` of its other axis, that no allocated storage holds (None if storage holds all): a
    chunked dataset's missing chunks, found by listing the allocated ones (their count first,
    which settles a complete dataset without a list); a contiguous one with no storage at all."""
    n = ds.shape[axis]
    if ds.chunks is None:
        return (0, n) if ds.id.get_storage_size() == 0 else None
    grid = [-(-size // chunk) for size, chunk in zip(ds.shape, ds.chunks)]
    if ds.id.get_num_chunks() == int(np.prod(grid)):
        return None
    step, other = ds.chunks[axis], 1 - axis
    lane = at - at % ds.chunks[other]
    held: set[int] = set()

    def add(info: Any) -> None:
        if info.chunk_offset[other] == lane:
            held.add(info.chunk_offset[axis])

    ds.id.chunk_iter(add)
    missing = [k for k in range(0, n, step) if k not in held]
    if not missing:
        return None
    stop = next((k for k in range(missing[0], n, step) if k in held), n)
    return missing[0], stop


def _text(value: Any) -> str:
    return value.decode("ascii", "replace") if isinstance(value, bytes) else str(value)


class Mat73Source:
    """The requested variables of a MATLAB v7.3 file, read in chunks by h5py's slicing."""

    kind = "MATLAB v7.3"
    rows = "samples"
    declared_fs = None
    note = ""

    def __init__(self, path: Path, columns: Sequence[Column]):
        self.path = path
        self.columns = {c.name: c for c in columns}
        self.labels = source_labels(columns, lambda c: f"variable {c.source!r}")
        with self._open() as f:
            #: per channel: the dataset's HDF5 path, its row to read (or None: its one column
            #: along axis 0), and how many samples
            self.where = {c.name: self._locate(f, c) for c in columns}
        one_column_each(
            path, self.labels, {name: w[:2] for name, w in self.where.items()}, "variable"
        )
        lengths = {name: w[2] for name, w in self.where.items()}
        self.n = one_length(path, "variables", self.labels, lengths)

    @contextmanager
    def _open(self) -> Iterator[Any]:
        import h5py

        try:
            f = h5py.File(self.path, "r")
        except OSError as err:
            raise ImportProblem(
                f"{self.path}: not a readable MATLAB v7.3 (HDF5) file ({short_error(err)})"
            ) from None
        try:
            with f:
                yield f
        except ImportProblem:
            raise
        except (OSError, ValueError, KeyError, TypeError) as err:
            raise ImportProblem(
                f"{self.path}: not a readable MATLAB v7.3 (HDF5) file ({short_error(err)})"
            ) from None

    def _locate(self, f: Any, c: Column) -> tuple[str, int | None, int]:
        import h5py

        where = c.source
        tokens = mat_tokens(self.path, c)
        node = f
        for k, (name, index) in enumerate(tokens):
            last = k == len(tokens) - 1
            if name.startswith("#") or name not in node:
                raise ImportProblem(f"{self.path}: no variable {where!r} (at {name!r})")
            item = node[name]
            if isinstance(item, h5py.Group):
                if index is not None:
                    raise ImportProblem(
                        f"{self.path}: {where!r}: {name} is a struct: a v7.3 file's struct "
                        "arrays are not read (save with save(..., '-v7'), or store the channels "
                        "as matrices)"
                    )
                if last:
                    fields = ", ".join(sorted(item)[:12])
                    raise ImportProblem(
                        f"{self.path}: {where!r} is a struct: name one of its fields ({fields})"
                    )
                node = item
                continue
            if not last:
                raise ImportProblem(
                    f"{self.path}: {where!r}: {name} is not a struct (no field "
                    f"{tokens[k + 1][0]!r})"
                )
            return self._dataset(item, c, name, index)
        raise AssertionError("unreachable: a path has a token")  # pragma: no cover

    def _dataset(self, ds: Any, c: Column, name: str, index: int | None) -> tuple[str, int, int]:
        import h5py

        where, path = c.source, self.path
        cls = _text(ds.attrs.get("MATLAB_class", b""))
        if cls == "cell" or h5py.check_dtype(ref=ds.dtype) is not None:
            what = "a cell array" if cls == "cell" else "a struct array"
            raise ImportProblem(
                f"{path}: {where!r} is {what} (object references in a v7.3 file), which the "
                "import does not read: store the channel as a matrix, or save with "
                "save(..., '-v7')"
            )
        if ds.attrs.get("MATLAB_empty", 0):
            raise ImportProblem(f"{path}: variable {where} is empty")
        if ds.dtype.names and {"real", "imag"} <= set(ds.dtype.names):
            raise ImportProblem(
                f"{path}: variable {where} is complex: save its real part, abs() or angle() instead"
            )
        if cls == "logical":
            raise ImportProblem(f"{path}: variable {where} is logical (true/false), not numbers")
        if cls == "char" or ds.dtype.kind not in "iuf":
            raise ImportProblem(f"{path}: {where!r} is not numeric")
        if ds.ndim != 2:
            raise ImportProblem(
                f"{path}: {where!r} has {ds.ndim} dimensions "
                f"({'×'.join(map(str, ds.shape[::-1]))}): the import reads a vector or a "
                "matrix's column: save the series as one"
            )
        cols, rows = ds.shape  # MATLAB's rows × cols, stored transposed
        if index is not None:
            if index > cols:
                raise ImportProblem(
                    f"{path}: {where!r}: {name}[{index}] does not exist ({name} is "
                    f"{rows}×{cols}; counted from 1)"
                )
            return self._written(ds, c, index - 1, rows)
        if rows == 1 and cols == 1:
            raise ImportProblem(f"{path}: {where!r} is a single value, not a series")
        if cols == 1:
            return self._written(ds, c, 0, rows)  # a column vector: the dataset's one row
        if rows == 1:
            return self._written(ds, c, None, cols)  # a row vector: the dataset's one column
        raise ImportProblem(
            f"{path}: {where!r} has size {rows}×{cols}: name one column, e.g. {where}[1] "
            f"(MATLAB's {where}(:,1))"
        )

    def _written(self, ds: Any, c: Column, row: int | None, n: int) -> tuple[str, int | None, int]:
        """The series (``row`` of the dataset, or its one column if None), refused where part
        of it was never written: HDF5 allocates a chunked dataset's chunks as they are written,
        and reads one never written (a preallocated variable whose logging stopped) as the fill
        value, which would be imported as data. Within a written chunk the file cannot tell a
        sample never written from one written as the fill value, so the written extent is known
        to a chunk only and no cut is trusted."""
        gap = unwritten(ds, 0 if row is None else 1, row or 0)
        if gap is not None:
            a, b = gap
            what = (
                f"none of its {n} samples was written"
                if (a, b) == (0, n)
                else f"its samples {a + 1}–{b} of {n} were never written"
            )
            kept = f": at most its first {a} samples hold data" if b == n and a else ""
            raise ImportProblem(
                f"{self.path}: {self.labels[c.name]}: {what} (no HDF5 storage holds them: a "
                "preallocated variable whose logging stopped) and would read as its fill value "
                f"{ds.fillvalue:g}{kept}; save the samples written and import those"
            )
        return ds.name, row, n

    @staticmethod
    def _read(ds: Any, row: int | None, start: int, stop: int) -> np.ndarray:
        values = ds[row, start:stop] if row is not None else ds[start:stop, 0]
        return np.asarray(values, dtype=np.float64)

    def chunks(self, progress: bool = False) -> Iterator[tuple[int, dict[str, np.ndarray]]]:
        with self._open() as f:
            for start in range(0, self.n, CHUNK_ROWS):
                stop = min(start + CHUNK_ROWS, self.n)
                yield (
                    start,
                    {
                        name: self._read(f[ds], row, start, stop)
                        for name, (ds, row, _) in self.where.items()
                    },
                )

    def varying(self, name: str) -> str:
        """For the refusal of a constant column of a matrix: its columns that vary."""
        c = self.columns[name]
        match = re.fullmatch(r"(.+)\[[0-9]+\]", str(c.source))
        if match is None:
            return ""
        ds_name = self.where[name][0]
        with self._open() as f:
            ds = f[ds_name]
            cols, rows = ds.shape
            lo, hi = np.full(cols, np.inf), np.full(cols, -np.inf)
            for start in range(0, rows, CHUNK_ROWS):
                a, b = column_spans(
                    np.asarray(ds[:, start : start + CHUNK_ROWS], dtype=np.float64), axis=1
                )
                lo, hi = np.fmin(lo, a), np.fmax(hi, b)
        return varying_columns(match.group(1), lo, hi)
