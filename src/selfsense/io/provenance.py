"""Outputs that appear atomically, with a provenance sidecar (docs/design.md, "Conventions").

Every table is a CSV plus ``<name>.csv.json`` holding the sha256 of its inputs, the config
subset it used, the code version (git describe, dirty flag), package versions and seed. Files
are written to a temporary name in the same folder and renamed, so an interrupted rule never
leaves a file that looks complete. Nothing time-dependent goes into a table, so rebuilding from
the same captures gives byte-identical tables.
"""

from __future__ import annotations

import errno
import glob
import hashlib
import inspect
import json
import logging
import os
import re
import socket
import subprocess
import sys
import time
from collections.abc import Callable, Iterable, Iterator, Mapping
from contextlib import contextmanager
from functools import lru_cache
from importlib import metadata
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:  # pandas only for annotations: ≈ 0.25 s of every job's start-up otherwise
    import pandas as pd

PACKAGES = (
    "selfsense",
    "numpy",
    "scipy",
    "pandas",
    "xarray",
    "netCDF4",
    "statsmodels",
    "numba",
    "control",
    "matplotlib",
    "snakemake",
)


#: a temporary is removed by another writer only when it was last modified this long ago [s].
#: Nothing else tells a live writer's temporary from a dead one's: writers on other hosts or in
#: other PID namespaces (containers, cluster nodes sharing the filesystem) have PIDs that mean
#: nothing here, so a PID test would remove files still being written. The longest job's time
#: limit is 2 h (config.yaml's resources: simulate_closed_loop), so a day is twelve times the
#: longest a live writer can have had its temporary, even one it has not modified since opening.
#: The price: a killed writer's temporary stays up to a day (no rule reads a ``.part`` name).
REAP_AGE_S = 24 * 3600
#: how a temporary's tag reads: ``<host>.<16 hex>`` (``<pid>-<8 hex>`` from earlier versions)
_TAG = re.compile(r"[A-Za-z0-9-]{1,32}\.[0-9a-f]{16}|\d+-[0-9a-f]{8}")


def temporary_path(path: str | os.PathLike, hidden: bool = False) -> Path:
    """A temporary name beside ``path`` that no other writer uses: ``<name>.<host>.<random>.part``
    (hidden: ``.<stem>.<host>.<random>.part<suffix>``, keeping the suffix that format-sniffing
    writers such as matplotlib need); ``<random>`` is 64 random bits, so names are unique across
    hosts, containers and processes, and ``<host>`` says where a leftover came from.

    Two runs that write the same output at once (a second Snakemake started with ``--nolock``,
    or after the lock was removed, or on another node) each write their own file and rename it
    whole, so neither can damage the other's. Temporaries not modified for :data:`REAP_AGE_S`
    (left by killed writers) are removed here, so reruns after kills do not pile them up.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    reap_stale_temporaries(path, hidden)
    tag = f"{_host()}.{os.urandom(8).hex()}"
    return path.with_name(
        f".{path.stem}.{tag}.part{path.suffix}" if hidden else f"{path.name}.{tag}.part"
    )


def reap_stale_temporaries(
    path: str | os.PathLike, hidden: bool = False, now: float | None = None
) -> list[Path]:
    """Remove the temporaries of ``path`` (named by :func:`temporary_path`) that were last
    modified more than :data:`REAP_AGE_S` ago; the ones removed. Only age decides, never the
    PID or host in a name: a writer elsewhere is alive whatever this host's process table says."""
    path = Path(path)
    now = time.time() if now is None else now
    if hidden:
        prefix, suffix = f".{path.stem}.", f".part{path.suffix}"
    else:
        prefix, suffix = f"{path.name}.", ".part"
    removed = []
    for stale in path.parent.glob(glob.escape(prefix) + "*" + glob.escape(suffix)):
        if not _TAG.fullmatch(stale.name[len(prefix) : len(stale.name) - len(suffix)]):
            continue  # another output's temporary, or a file that is not a temporary
        try:
            if now - stale.stat().st_mtime <= REAP_AGE_S:
                continue
            stale.unlink()
        except FileNotFoundError:  # renamed by its writer, or removed by another reaper
            continue
        removed.append(stale)
    return removed


def _host() -> str:
    """This host's name as a temporary's tag: its first label, letters, digits and '-' only."""
    label = re.sub(r"[^A-Za-z0-9-]", "-", socket.gethostname().split(".")[0])[:32]
    return label or "host"


#: what a failed write's errno means for the folder of the file written (a capture, a series, a
#: table, a figure, a report)
WRITE_ERRNO = {
    errno.ENOSPC: "no space left on device",
    errno.EDQUOT: "disk quota exceeded",
    errno.EROFS: "folder is read-only (read-only file system)",
    errno.EACCES: "folder is read-only (permission denied)",
    errno.EPERM: "folder is read-only (operation not permitted)",
    errno.EFBIG: "file too large (the file system's or the process's file size limit)",
}
#: the errnos that can only mean the write failed, whichever file the OS names (pandas and
#: matplotlib raise a full disk's ENOSPC on a flush, with no file name)
_WRITE_ONLY_ERRNO = (errno.ENOSPC, errno.EDQUOT, errno.EROFS, errno.EFBIG)


class OutputWriteError(OSError):
    """An output (table, figure, report) its folder cannot take: one line,
    ``<file>: cannot write the output: no space left on device``. An OSError still (errno,
    strerror and filename are the output's), so callers that handle file-system errors do."""

    def __init__(self, path: str | os.PathLike, err: OSError):
        reason = WRITE_ERRNO.get(err.errno, err.strerror or str(err))
        super().__init__(err.errno, reason, os.fspath(path))

    def __str__(self) -> str:
        return f"{self.filename}: cannot write the output: {self.strerror}"


def _is_write_error(err: OSError, *paths: Path) -> bool:
    """Whether ``err`` is the folder refusing one of ``paths`` (not an input failing to open)."""
    if err.errno in _WRITE_ONLY_ERRNO:
        return True
    named = {os.fspath(p) for p in paths}
    return err.errno in WRITE_ERRNO and os.fspath(err.filename or "") in named


@contextmanager
def atomic_path(path: str | os.PathLike) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; rename it over ``path`` only on success. A full
    disk, a quota or a read-only folder is :class:`OutputWriteError`, naming ``path``; no
    temporary is left."""
    path = Path(path)
    try:
        tmp = temporary_path(path, hidden=True)
    except OSError as err:  # the folder cannot be made
        if _is_write_error(err, path, path.parent):
            raise OutputWriteError(path, err) from None
        raise
    try:
        yield tmp
        os.replace(tmp, path)
    except OSError as err:
        if not isinstance(err, OutputWriteError) and _is_write_error(err, path, tmp):
            raise OutputWriteError(path, err) from None
        raise
    finally:
        try:
            tmp.unlink(missing_ok=True)
        except OSError:  # a read-only folder: its error is the one raised
            pass


def sha256(path: str | os.PathLike) -> str:
    """The file's SHA-256, read once per process for a given size and modification time: a rule
    that writes a table and a figure from the same captures records both without reading the
    captures twice (gigabytes on the thesis's Chapter 7 runs)."""
    st = os.stat(path)
    return _sha256(os.fspath(path), st.st_size, st.st_mtime_ns)


@lru_cache(maxsize=4096)
def _sha256(path: str, size: int, mtime_ns: int) -> str:
    return file_sha256(path)


def file_sha256(path: str | os.PathLike, block: int = 1 << 20) -> str:
    """The file's SHA-256, read now (streamed, ``block`` bytes at a time), whatever was read
    before: :func:`sha256` caches it for the process, :class:`selfsense.io.audit.Hashes` for one
    audit."""
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        while chunk := fh.read(block):
            h.update(chunk)
    return h.hexdigest()


@lru_cache(maxsize=1)
def code_version() -> dict[str, Any]:
    root = Path.cwd()  # the checkout the workflow runs in (the package may be installed elsewhere)
    try:
        describe = subprocess.run(
            ["git", "describe", "--always", "--dirty", "--tags"],
            cwd=root,
            capture_output=True,
            text=True,
            timeout=10,
        ).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        describe = ""
    return {
        "git_describe": describe or "unknown",
        "dirty": describe.endswith("-dirty"),
        "python": sys.version.split()[0],
        "packages": {p: _version(p) for p in PACKAGES},
    }


@lru_cache(maxsize=1)
def commit() -> str:
    """The checkout's commit (``git rev-parse HEAD`` where the workflow runs; "unknown" outside
    a git checkout): what an output that names its commit records."""
    try:
        head = subprocess.run(
            ["git", "rev-parse", "HEAD"], cwd=Path.cwd(), capture_output=True, text=True, timeout=10
        ).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        head = ""
    return head or "unknown"


def _version(package: str) -> str:
    try:
        return metadata.version(package)
    except metadata.PackageNotFoundError:
        return "not installed"


def provenance(
    inputs: Iterable[str | os.PathLike],
    config: Mapping[str, Any] | None = None,
    seed: int | None = None,
    **extra: Any,
) -> dict[str, Any]:
    config = dict(config or {})
    stats = {str(p): os.stat(p) for p in inputs}
    return {
        "inputs": {p: _sha256(p, st.st_size, st.st_mtime_ns) for p, st in stats.items()},
        # what the inputs' sha256 were taken of: a start-of-run check compares these and hashes
        # only a file whose size or mtime differ (selfsense.io.audit.check_inputs_unchanged)
        "input_files": {
            p: {"size": st.st_size, "mtime_ns": st.st_mtime_ns} for p, st in stats.items()
        },
        "config": config,
        "config_sha256": hashlib.sha256(
            json.dumps(config, sort_keys=True, default=str).encode()
        ).hexdigest(),
        "code": code_version(),
        "seed": seed,
        **extra,
    }


def write_json(obj: Any, path: str | os.PathLike) -> None:
    with atomic_path(path) as tmp:
        tmp.write_text(json.dumps(obj, indent=2, sort_keys=True, default=_jsonable) + "\n")


def read_records(paths: Iterable[str | os.PathLike]) -> list[dict[str, Any]]:
    """JSON reports written with :func:`write_json`, without their provenance (a summary table's
    rows)."""
    return [
        {k: v for k, v in json.loads(Path(p).read_text()).items() if k != "provenance"}
        for p in paths
    ]


def _jsonable(value: Any) -> Any:
    if hasattr(value, "tolist"):
        return value.tolist()
    return str(value)


def write_table(
    table: pd.DataFrame,
    path: str | os.PathLike,
    inputs: Iterable[str | os.PathLike] = (),
    config: Mapping[str, Any] | None = None,
    seed: int | None = None,
    **extra: Any,
) -> None:
    """CSV (tidy, units in headers, fixed float format) plus its JSON provenance sidecar. Text a
    spreadsheet would run as a formula is written inert (:func:`spreadsheet_safe`)."""
    with atomic_path(path) as tmp:
        spreadsheet_safe(table).to_csv(tmp, index=False, float_format="%.10g", lineterminator="\n")
    _with_sidecar([path], provenance(inputs, config, seed, **extra), f"{path}.json")


def _with_sidecar(outputs: Iterable[str | os.PathLike], record: Any, sidecar: str) -> None:
    """Write the outputs' provenance sidecar; if it cannot be written (a full disk), remove the
    outputs too: an output without its sidecar would pass for one made before provenance."""
    try:
        write_json(record, sidecar)
    except BaseException:
        for output in outputs:
            Path(output).unlink(missing_ok=True)
        raise


#: a text cell that starts with one of these is a formula to a spreadsheet (OWASP, "CSV Injection")
FORMULA_START = ("=", "+", "-", "@", "\t", "\r")
#: text after a leading + or - that stays as it is: nothing (a lone sign, as a table's "-"), a
#: number, or a number, a space and words without a character a formula acts with (a function's
#: parenthesis, DDE's | and !, an operator, a string's quote): "+2 %, same factor below", "-1.5e-3"
_SIGNED_TEXT = re.compile(
    r"[+-](?:(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?(?: [^()|!=+\-*/^&@;\"]*)?|inf|nan)?",
    re.IGNORECASE,
)


def spreadsheet_cell(value: Any) -> Any:
    """``value`` with a ``'`` in front if it is text a spreadsheet would evaluate as a formula
    (starts with ``=``, ``@``, a tab or a carriage return, or with ``+``/``-`` followed by more
    than a number and plain words: :data:`_SIGNED_TEXT`); any other value as it is (numbers are
    never touched)."""
    if (
        isinstance(value, str)
        and value.startswith(FORMULA_START)
        and not _SIGNED_TEXT.fullmatch(value)
    ):
        return "'" + value
    return value


def spreadsheet_safe(table: pd.DataFrame) -> pd.DataFrame:
    """``table`` with every text cell :func:`spreadsheet_cell` would change changed (a copy; the
    table itself when none is): a manifest's text such as ``=HYPERLINK(…)`` reaches a result table
    as data, and a spreadsheet shows it instead of running it. Numeric, boolean and time columns
    are not read."""
    from pandas.api.types import is_bool_dtype, is_datetime64_any_dtype, is_numeric_dtype

    out = table
    for i, kind in enumerate(table.dtypes):
        if is_numeric_dtype(kind) or is_bool_dtype(kind) or is_datetime64_any_dtype(kind):
            continue
        cells = table.iloc[:, i].map(spreadsheet_cell)
        if not cells.equals(table.iloc[:, i]):
            out = table.copy() if out is table else out
            out.isetitem(i, cells)
    return out


def save_figure(
    fig,
    path: str | os.PathLike,
    inputs: Iterable[str | os.PathLike] = (),
    config: Mapping[str, Any] | None = None,
    pdf: bool = True,
    **extra: Any,
) -> None:
    """PNG at ``path`` and, with ``pdf``, a PDF beside it (config.yaml's ``figures.pdf``), each
    atomically, plus the provenance sidecar. Without ``pdf`` a PDF an earlier run left beside
    it is removed: it would show another figure than the PNG."""
    path, beside = Path(path), Path(path).with_suffix(".pdf")
    if not pdf:
        beside.unlink(missing_ok=True)
    for target in (path, beside) if pdf else (path,):
        with atomic_path(target) as tmp:
            fig.savefig(
                tmp,
                format=target.suffix[1:],
                dpi=150,
                bbox_inches="tight",
                metadata={"CreationDate": None} if target.suffix == ".pdf" else {"Software": None},
            )
    _with_sidecar(
        [path, beside] if pdf else [path], provenance(inputs, config, **extra), f"{path}.json"
    )


def modified_utc(path: str | os.PathLike) -> str:
    """When a file was last written (its mtime), in UTC to the minute."""
    return time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime(Path(path).stat().st_mtime))


#: the input every rule has that its script does not read: the selfsense files the script runs
#: (``library_sources`` in workflow/rules/common.smk), there so that a library edit reruns the
#: rule; the sidecar's code version records them, so they are not provenance inputs
LIBRARY = "library"


def run(main: Callable[..., Any], snakemake: Any) -> Any:
    """Call a rule's script's ``main`` with the rule's names: its inputs (except
    :data:`LIBRARY`), outputs and params by name, ``log`` (its log file) and ``inputs`` (its
    provenance inputs: every input file but the library's, a folder as its files). A rule's
    input may go unread (a capture's QC report orders the job after the check; a list whose
    pairing a param gives) and is still a provenance input; an output or param ``main`` does not
    take, a parameter of ``main`` the rule does not give, or a name given twice (an input and a
    param alike) stops the job with one line naming the rule and the name, before anything is
    read."""
    library = set(snakemake.input.get(LIBRARY) or ())
    named = {
        "an input": [(k, v) for k, v in snakemake.input.items() if k != LIBRARY],
        "an output": snakemake.output.items(),
        "a param": snakemake.params.items(),
        "a name run gives main itself": [
            ("log", snakemake.log[0] if snakemake.log else None),
            ("inputs", _files([p for p in snakemake.input if p not in library])),
        ],
    }
    given: dict[str, tuple[str, Any]] = {}
    for kind, items in named.items():
        for name, value in items:
            if name in given:
                _refuse(snakemake, f"{name!r} is both {given[name][0]} and {kind}")
            given[name] = (kind, value)
    takes = inspect.signature(main).parameters
    rest = any(p.kind is p.VAR_KEYWORD for p in takes.values())
    for name, p in takes.items():
        if p.kind is not p.VAR_KEYWORD and p.default is p.empty and name not in given:
            _refuse(snakemake, f"main needs {name!r}, none of its inputs, outputs and params")
    # every output and param reaches main: by its name, or in its **kwargs (a figure rule's
    # outputs); an input main does not name reaches it only through ``inputs``
    must = {name for name, (kind, _) in given.items() if kind in ("an output", "a param")}
    for name in [] if rest else sorted(must - set(takes)):
        _refuse(snakemake, f"{name!r} is {given[name][0]} but no parameter of main")
    return main(**{n: v for n, (_, v) in given.items() if n in takes or (rest and n in must)})


def _files(inputs: list[str]) -> list[str]:
    """Input files, a folder's (a ``directory()`` output of another rule) as the files in it."""
    files = []
    for path in inputs:
        folder = Path(path)
        inside = sorted(str(f) for f in folder.rglob("*") if f.is_file())
        files += inside if folder.is_dir() else [path]
    return files


def _refuse(snakemake: Any, why: str) -> None:
    """Stop a rule's script before it starts, its one-line reason in the rule's log too."""
    script_logging(snakemake.log[0] if snakemake.log else None)
    raise TypeError(f"rule {snakemake.rule}: {why}")


def script_logging(
    log_path: str | os.PathLike | None, inputs: Iterable[str | os.PathLike] | None = None
) -> logging.Logger:
    """Log a rule's script to its ``log:`` file (or stderr when run alone). A failure's one-line
    reason goes to the log; one whose job's input is gone (``inputs``, by default the rule's,
    ``snakemake.input`` of the script Snakemake runs) is that one line on the terminal too,
    without a traceback."""
    logger = logging.getLogger("selfsense")
    logger.setLevel(logging.INFO)
    handler = logging.FileHandler(log_path, mode="w") if log_path else logging.StreamHandler()
    handler.setFormatter(logging.Formatter("%(levelname)s %(message)s"))
    logger.handlers[:] = [handler]
    if log_path:
        sys.excepthook = _log_then_raise(
            logger, sys.__excepthook__, inputs
        )  # once, however often this runs
    return logger


def _log_then_raise(logger: logging.Logger, hook, inputs=None):
    """An excepthook that first writes the failure's one-line reason to the rule's log:
    Snakemake points the user at that file, and the traceback goes only to the terminal. When an
    input of the job is gone, that is the reason, and the terminal gets the same line alone:
    Snakemake saw every input before it started the job, so another run (or a hand) removed it
    while the job ran, and nothing in the code failed."""

    def excepthook(kind, error, tb):
        gone = missing_inputs(_job_inputs() if inputs is None else inputs)
        if gone:
            line = missing_input_line(gone, error)
            logger.error("%s", line)
            print(line, file=sys.stderr)
            return
        logger.error("%s", one_line_reason(error))
        hook(kind, error, tb)

    return excepthook


def _job_inputs() -> list[str]:
    """The input files of the rule whose script this is (``snakemake.input`` in the script
    Snakemake runs as ``__main__``); none outside Snakemake."""
    job = getattr(sys.modules.get("__main__"), "snakemake", None)
    return [str(p) for p in getattr(job, "input", ())]


def missing_inputs(inputs: Iterable[str | os.PathLike]) -> list[str]:
    """Those of ``inputs`` that are not there now."""
    return [str(p) for p in inputs if not os.path.exists(p)]


def missing_input_line(gone: list[str], error: BaseException) -> str:
    """``<input>: missing input: …``, one line naming the first input gone (and how many more)
    and what the job stopped on."""
    more = f" (and {len(gone) - 1} more: {', '.join(gone[1:3])}{' …' if len(gone) > 3 else ''})"
    stopped = one_line_reason(error)
    stopped = stopped if len(stopped) <= 200 else stopped[:197] + "..."
    return (
        f"{gone[0]}{more if len(gone) > 1 else ''}: missing input: it was there when this job "
        "started and was removed while it ran (by another run, or by hand); run again, and "
        f"Snakemake makes it anew or says why it cannot (the job stopped on: {stopped})"
    )


def one_line_reason(error: BaseException) -> str:
    """The message the user needs: ours are one line naming the file already; others get their
    type in front."""
    text = " ".join(str(error).split())
    if any(
        c.__name__ in ("CaptureError", "ManifestError", "OutputWriteError")
        for c in type(error).__mro__
    ):
        return text
    return f"{type(error).__name__}: {text}" if text else type(error).__name__
