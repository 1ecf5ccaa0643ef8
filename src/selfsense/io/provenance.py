"""Outputs that appear atomically, with a provenance sidecar (docs/design.md, "Conventions").

Every table is a CSV plus ``<name>.csv.json`` holding the sha256 of its inputs, the config
subset it used, the code version (git describe, dirty flag), package versions and seed. Files
are written to a temporary name in the same folder and renamed, so an interrupted rule never
leaves a file that looks complete. Nothing time-dependent goes into a table, so rebuilding from
the same captures gives byte-identical tables.
"""

from __future__ import annotations

import hashlib
import json
import logging
import os
import re
import subprocess
import sys
from collections.abc import Iterable, Iterator, Mapping
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


def temporary_path(path: str | os.PathLike, hidden: bool = False) -> Path:
    """A temporary name beside ``path`` that no other writer uses: ``<name>.<pid>-<random>.part``
    (hidden: ``.<stem>.<pid>-<random>.part<suffix>``, keeping the suffix that format-sniffing
    writers such as matplotlib need).

    Two runs that write the same output at once (a second Snakemake started with ``--nolock``,
    or after the lock was removed) each write their own file and rename it whole, so neither can
    damage the other's. Temporaries of writers that no longer run (killed) are removed here, so
    reruns after kills do not pile them up.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    pattern = f".{path.stem}.*.part{path.suffix}" if hidden else f"{path.name}.*.part"
    for stale in path.parent.glob(pattern):
        tag = re.search(r"\.(\d+)-[0-9a-f]{8}\.part", stale.name)
        if tag and not _running(int(tag.group(1))):
            stale.unlink(missing_ok=True)
    tag = f"{os.getpid()}-{os.urandom(4).hex()}"
    return path.with_name(
        f".{path.stem}.{tag}.part{path.suffix}" if hidden else f"{path.name}.{tag}.part"
    )


def _running(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # another user's process
        return True
    return True


@contextmanager
def atomic_path(path: str | os.PathLike) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; rename it over ``path`` only on success."""
    path = Path(path)
    tmp = temporary_path(path, hidden=True)
    try:
        yield tmp
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)


def sha256(path: str | os.PathLike) -> str:
    """The file's SHA-256, read once per process for a given size and modification time: a rule
    that writes a table and a figure from the same captures records both without reading the
    captures twice (gigabytes on the thesis's Chapter 7 runs)."""
    st = os.stat(path)
    return _sha256(os.fspath(path), st.st_size, st.st_mtime_ns)


@lru_cache(maxsize=4096)
def _sha256(path: str, size: int, mtime_ns: int, block: int = 1 << 20) -> str:
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
    return {
        "inputs": {str(p): sha256(p) for p in inputs},
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
    """CSV (tidy, units in headers, fixed float format) plus its JSON provenance sidecar."""
    with atomic_path(path) as tmp:
        table.to_csv(tmp, index=False, float_format="%.10g", lineterminator="\n")
    write_json(provenance(inputs, config, seed, **extra), f"{path}.json")


def save_figure(
    fig,
    path: str | os.PathLike,
    inputs: Iterable[str | os.PathLike] = (),
    config: Mapping[str, Any] | None = None,
    **extra: Any,
) -> None:
    """PNG at ``path`` and a PDF beside it, each atomically, plus the provenance sidecar."""
    path = Path(path)
    for target in (path, path.with_suffix(".pdf")):
        with atomic_path(target) as tmp:
            fig.savefig(
                tmp,
                format=target.suffix[1:],
                dpi=150,
                bbox_inches="tight",
                metadata={"CreationDate": None} if target.suffix == ".pdf" else {"Software": None},
            )
    write_json(provenance(inputs, config, **extra), f"{path}.json")


def script_logging(log_path: str | os.PathLike | None) -> logging.Logger:
    """Log a rule's script to its ``log:`` file (or stderr when run alone)."""
    logger = logging.getLogger("selfsense")
    logger.setLevel(logging.INFO)
    handler = logging.FileHandler(log_path, mode="w") if log_path else logging.StreamHandler()
    handler.setFormatter(logging.Formatter("%(levelname)s %(message)s"))
    logger.handlers[:] = [handler]
    if log_path:
        sys.excepthook = _log_then_raise(
            logger, sys.__excepthook__
        )  # once, however often this runs
    return logger


def _log_then_raise(logger: logging.Logger, hook):
    """An excepthook that first writes the failure's one-line reason to the rule's log:
    Snakemake points the user at that file, and the traceback goes only to the terminal."""

    def excepthook(kind, error, tb):
        logger.error("%s", one_line_reason(error))
        hook(kind, error, tb)

    return excepthook


def one_line_reason(error: BaseException) -> str:
    """The message the user needs: ours are one line naming the file already; others get their
    type in front."""
    text = " ".join(str(error).split())
    if any(c.__name__ in ("CaptureError", "ManifestError") for c in type(error).__mro__):
        return text
    return f"{type(error).__name__}: {text}" if text else type(error).__name__
