"""A lab's own recording into the capture contract (docs/bring-your-own-data.md).

Reads CSV/TSV (columns by name or index) or MATLAB ``.mat`` files up to v7 (``scipy.io.loadmat``;
variables by name, struct fields by ``.``, a column of a matrix or an element of a struct array by
``[k]``), converts each channel to its contract unit, checks the time axis, packs int16 with the
manifest's ranges (or ranges derived from the data) and writes ``raw/<dataset>/<experiment>.nc``,
then scaffolds or updates ``raw/<dataset>/dataset.yaml``. The capture appears only complete and
verified (:class:`~selfsense.io.capture.CaptureWriter`), the manifest by an atomic rename, the
capture first: an interrupted import leaves at most a complete capture the manifest does not
list yet. An existing capture is never overwritten (measured captures are only ever read).
"""

from __future__ import annotations

import logging
import math
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from selfsense import __version__
from selfsense.io.capture import CHANNEL_UNITS, SLOW_CHANNELS, CaptureWriter, channel_spec
from selfsense.io.contract import clipping_problem
from selfsense.io.manifest import (
    ManifestError,
    check_dataset_name,
    check_experiment_name,
    load_dataset,
    validate_document,
)
from selfsense.io.provenance import atomic_path

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
#: rows read per CSV chunk (progress is logged every PROGRESS_STEP of the file)
CSV_CHUNK_ROWS = 1 << 18
PROGRESS_STEP = 0.1


class ImportProblem(ValueError):
    """An input the import cannot turn into a capture; one line naming the file and the problem."""


@dataclass(frozen=True)
class Column:
    """Where a channel (or the time) is in the source file, and its unit there."""

    name: str  # contract channel, or "time"
    source: str | int  # column name or index (CSV), variable path (MAT)
    unit: str


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


def read_csv(
    path: Path, columns: Sequence[Column], sep: str | None = None, header: bool = True
) -> dict[str, np.ndarray]:
    """The columns of a CSV/TSV file as float64 (NaN where a cell is empty), read in chunks."""
    import pandas as pd

    sep = sep or ("\t" if path.suffix.lower() in (".tsv", ".tab") else ",")
    size, parts, next_log = (
        max(path.stat().st_size, 1),
        {c.name: [] for c in columns},
        PROGRESS_STEP,
    )
    with open(path, "rb") as handle:
        try:
            reader = pd.read_csv(
                handle,
                sep=sep,
                header=0 if header else None,
                chunksize=CSV_CHUNK_ROWS,
                skipinitialspace=True,
            )
            for chunk in reader:
                for c in columns:
                    parts[c.name].append(_column(path, chunk, c))
                if handle.tell() / size >= next_log:
                    LOG.info("%s: %3.0f %% read", path, 100 * handle.tell() / size)
                    next_log = math.floor(handle.tell() / size / PROGRESS_STEP + 1) * PROGRESS_STEP
        except (pd.errors.ParserError, UnicodeDecodeError, pd.errors.EmptyDataError) as err:
            raise ImportProblem(
                f"{path}: not a readable {'TSV' if sep == chr(9) else 'CSV'} file "
                f"({' '.join(str(err).split())})"
            ) from None
    return {k: np.concatenate(v) if v else np.empty(0) for k, v in parts.items()}


def _column(path: Path, chunk, c: Column) -> np.ndarray:
    import pandas as pd

    names = list(chunk.columns)
    if isinstance(c.source, int) and c.source not in names:  # an index into a file with a header
        if c.source >= len(names):
            raise ImportProblem(
                f"{path}: column {c.source} for {c.name} does not exist ({len(names)} columns)"
            )
        series = chunk.iloc[:, c.source]
    elif c.source in names:
        series = chunk[c.source]
    else:
        raise ImportProblem(
            f"{path}: no column {c.source!r} for {c.name} (columns: {', '.join(map(str, names))})"
        )
    values = pd.to_numeric(series, errors="coerce")
    bad = values.isna() & series.notna() & (series.astype(str).str.strip() != "")
    if bad.any():
        raise ImportProblem(
            f"{path}: column {c.source!r} ({c.name}) holds {series[bad].iloc[0]!r}, not a number"
        )
    return values.to_numpy(dtype=np.float64)


def read_mat(path: Path, columns: Sequence[Column]) -> dict[str, np.ndarray]:
    """The variables of a MATLAB file (v4–v7) as float64 vectors."""
    from scipy.io import loadmat
    from scipy.io.matlab import MatReadError

    try:
        doc = loadmat(path, squeeze_me=True, struct_as_record=False)
    except NotImplementedError:
        raise ImportProblem(
            f"{path}: a MATLAB v7.3 (HDF5) file: save it with save(..., '-v7') or export "
            "CSV (v7.3 would need h5py, not a dependency)"
        ) from None
    except (MatReadError, ValueError, OSError) as err:
        raise ImportProblem(
            f"{path}: not a readable MATLAB file ({' '.join(str(err).split())})"
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
    try:
        values = np.asarray(node, dtype=np.float64)
    except (TypeError, ValueError):
        raise ImportProblem(f"{path}: {where!r} is not numeric") from None
    if values.ndim != 1:
        raise ImportProblem(
            f"{path}: {where!r} has shape {values.shape}: name one column, e.g. {where}[0]"
        )
    return values


def sampling(path: Path, time: np.ndarray | None, fs: float | None) -> tuple[float, str]:
    """fs [Hz] from the time column (checked uniform to a quarter sample, as the contract's time
    axis is) or as given, and a note when the time axis did not start at 0."""
    if time is None:
        if fs is None:
            raise ImportProblem(
                f"{path}: give the time column (--time) or the sampling rate (--fs)"
            )
        return float(fs), ""
    n = len(time)
    if n < 2 or not np.isfinite(time).all():
        raise ImportProblem(f"{path}: the time column needs at least two finite values")
    derived = (n - 1) / (time[-1] - time[0]) if time[-1] > time[0] else math.nan
    if not (math.isfinite(derived) and derived > 0):
        raise ImportProblem(f"{path}: the time column does not increase")
    if fs is not None and not math.isclose(derived, fs, rel_tol=1e-3):
        raise ImportProblem(
            f"{path}: the time column gives fs = {derived:g} Hz, --fs says {fs:g} Hz"
        )
    off = np.abs(time - time[0] - np.arange(n) / derived) > 0.25 / derived
    if off.any():
        k = int(np.argmax(off))
        raise ImportProblem(
            f"{path}: the time column is not sampled at a fixed rate: sample {k} is at "
            f"{time[k]:.9g} s, {time[0] + k / derived:.9g} s expected at fs = {derived:g} Hz "
            "(a gap or a restart: split the file, or export at a fixed rate)"
        )
    note = (
        f"time axis started at {time[0]:.9g} s in the source; shifted to 0" if time[0] != 0 else ""
    )
    return float(fs) if fs is not None else float(
        f"{derived:.9g}"
    ), note  # 1/Δt's rounding noise off


def derived_range(values: np.ndarray) -> tuple[float, float]:
    """An ADC range for data without one: the data's span with RANGE_MARGIN free on each side,
    rounded outward to three significant digits."""
    lo, hi = float(np.nanmin(values)), float(np.nanmax(values))
    span = hi - lo or max(abs(hi), 1e-12)
    lo, hi = lo - RANGE_MARGIN * span, hi + RANGE_MARGIN * span
    e = math.floor(math.log10(hi - lo)) - 2
    return float(f"{math.floor(lo / 10.0**e)}e{e}"), float(
        f"{math.ceil(hi / 10.0**e)}e{e}"
    )  # exact decimals


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


def run_import(req: Request) -> tuple[Path, Path]:
    """Write the capture and the manifest of one import; returns their paths."""
    folder = Path(req.raw_dir) / req.dataset
    manifest_path, capture_path = folder / "dataset.yaml", folder / f"{req.experiment}.nc"
    check_dataset_name(req.dataset, "--dataset")
    check_experiment_name(req.experiment, "--experiment")
    if capture_path.exists():
        raise ImportProblem(
            f"{capture_path} exists: measured captures are never overwritten "
            "(remove it to import again)"
        )
    if not req.source.exists():
        raise ImportProblem(f"{req.source}: no such file")
    if len({c.name for c in req.channels}) != len(req.channels) or not req.channels:
        raise ImportProblem(f"{req.source}: name each channel once (--channel)")
    slow = [c.name for c in req.channels if c.name in SLOW_CHANNELS]
    if slow:  # they run at their own rate on their own time axis (the contract's time_slow)
        raise ImportProblem(
            f"{req.source}: {slow[0]} is a slow (thermometer) channel, which the import "
            "does not take yet; leave it out"
        )
    columns = [*req.channels, *([req.time] if req.time else [])]
    mat = req.source.suffix.lower() == ".mat"
    data = (
        read_mat(req.source, columns) if mat else read_csv(req.source, columns, req.sep, req.header)
    )
    lengths = {len(v) for v in data.values()}
    if len(lengths) != 1 or 0 in lengths:
        raise ImportProblem(
            f"{req.source}: the columns differ in length or are empty ({sorted(lengths)})"
        )
    time = data.pop("time") * UNITS["s"][req.time.unit] if req.time else None
    fs, note = sampling(req.source, time, req.fs)
    values = {c.name: data[c.name] * UNITS[CHANNEL_UNITS[c.name][0]][c.unit] for c in req.channels}
    manifest = _manifest(manifest_path, req, fs, values)
    ranges = {c: tuple(manifest["daq"]["ranges"][c]) for c in values}
    for channel, v in values.items():
        lo, hi = ranges[channel]
        problem = clipping_problem(
            channel, int(np.count_nonzero((v < lo) | (v > hi))), len(v), lo, hi, manifest_path
        )
        if problem:
            raise ImportProblem(f"{req.source}: {problem}")
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
    folder.mkdir(parents=True, exist_ok=True)
    n = lengths.pop()
    specs = [channel_spec(c, *ranges[c]) for c in values]
    chunk = 1 << 16
    with CaptureWriter(capture_path, attrs, specs, n, chunk_len=chunk) as writer:
        for start in range(0, n, chunk):
            writer.write({c: v[start : start + chunk] for c, v in values.items()})
    _write_manifest(manifest, manifest_path)
    if note:
        LOG.info("%s: %s", capture_path, note)
    return capture_path, manifest_path


def _manifest(path: Path, req: Request, fs: float, values: Mapping[str, np.ndarray]) -> dict:
    """The dataset's manifest with this import in it: scaffolded, or the existing one updated
    (its fs must be this file's; a channel it already has keeps its range)."""
    if path.exists():
        manifest = load_dataset(path.parent.parent, path.parent.name)
        if manifest["source"] != "measured":
            raise ImportProblem(
                f"{path}: source is {manifest['source']}: import into a measured dataset"
            )
        if not math.isclose(manifest["daq"]["fs"], fs, rel_tol=1e-6):
            raise ImportProblem(
                f"{req.source}: fs = {fs:g} Hz, "
                f"{path} declares daq.fs = {manifest['daq']['fs']:g} Hz"
            )
    else:
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
    daq = manifest["daq"]
    for channel, v in values.items():
        given = (req.ranges or {}).get(channel)
        if channel in daq["ranges"] and given and tuple(given) != tuple(daq["ranges"][channel]):
            raise ImportProblem(
                f"--range {channel}={given[0]:g},{given[1]:g} differs from daq.ranges.{channel} "
                f"= {daq['ranges'][channel]} in {path}"
            )
        daq["ranges"].setdefault(channel, list(given) if given else list(derived_range(v)))
        if channel not in daq["channels"]:
            daq["channels"].append(channel)
    manifest.setdefault("experiments", [])
    if req.experiment in manifest["experiments"]:
        raise ImportProblem(
            f"{path}: experiment {req.experiment} is listed already, without its capture"
        )
    manifest["experiments"].append(req.experiment)
    return manifest


def _write_manifest(manifest: Mapping[str, Any], path: Path) -> None:
    """Validated first (nothing invalid is written), then written by an atomic rename."""
    doc = yaml.safe_load(
        yaml.safe_dump(dict(manifest), sort_keys=False)
    )  # plain types, as a reader will see them
    try:
        validate_document(doc, "dataset.schema.yaml", path)
    except ManifestError as err:
        raise ImportProblem(str(err)) from None
    with atomic_path(path) as tmp:
        tmp.write_text(yaml.safe_dump(doc, sort_keys=False, allow_unicode=True))


def parse_range(text: str) -> tuple[str, tuple[float, float]]:
    """``x_laser=-1e-4,1e-4`` (contract units) → ("x_laser", (-1e-4, 1e-4))."""
    channel, _, rest = text.partition("=")
    try:
        lo, hi = (float(v) for v in rest.split(","))
    except ValueError:
        raise ImportProblem(
            f"--range {text!r}: expected CHANNEL=LOW,HIGH in the contract's unit"
        ) from None
    if channel not in CHANNEL_UNITS or not lo < hi:
        raise ImportProblem(f"--range {text!r}: a contract channel and LOW < HIGH")
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
