"""Whether an output still describes its inputs, by content (docs/auditing.md).

Snakemake re-makes an output when an input is newer than it. An input replaced by other bytes
with an older modification time (``cp -p``, ``tar x``, ``rsync -t`` of a different file) is not
newer, so a run says "Nothing to be done" while its results describe the old input. Every
output's provenance records the sha256 of each input it was made from
(:func:`selfsense.io.provenance.provenance`); :func:`audit` hashes the inputs now and names what
differs or is gone (``selfsense audit``), and :func:`check_inputs_unchanged` is the cheap check
the Snakefile makes at every start for the captures of measured datasets.
"""

from __future__ import annotations

import json
import os
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from selfsense.io.provenance import file_sha256

#: how a re-make is spelled in a hint: the checkout's own Snakemake (README.md)
SNAKEMAKE = ".venv/bin/snakemake --cores 2"
#: hex digits of a sha256 shown in a line (enough to tell two apart; `sha256sum` shows all)
SHOWN_HEX = 12


class ProvenanceError(ValueError):
    """An output whose provenance cannot be read; the message is one line naming the file."""


class StaleInput(ValueError):
    """A measured dataset's input whose content changed without a newer mtime (one line)."""


@dataclass(frozen=True)
class Stale:
    """One reason an output no longer describes its inputs."""

    output: str
    #: "changed", "missing input", "unreadable input", "stale input" (an input made by the
    #: workflow that is stale itself: ``cause`` says why), "missing output" or "no provenance"
    problem: str
    input: str | None = None
    recorded: str | None = None
    now: str | None = None
    detail: str = ""
    cause: Stale | None = None

    def summary(self) -> str:
        """What is wrong, without the output's name or the way out."""
        if self.problem == "changed":
            return f"input {self.input} changed since it was made"
        if self.problem == "missing input":
            return f"input {self.input} is missing"
        if self.problem == "missing output":
            return "missing (its provenance is there)"
        if self.problem == "stale input":
            root = self.root()
            first = "the first cause: " if self.cause is not root else ""
            return f"input {self.input} is stale itself ({first}{root.output}: {root.summary()})"
        return self.detail

    def root(self) -> Stale:
        """The first reason down a chain of stale inputs."""
        return self.cause.root() if self.cause is not None else self

    def line(self) -> str:
        """The one line ``selfsense audit`` prints: what is stale and how to re-make it."""
        root = self.root()
        if root.problem == "changed":
            # touch, not -f: Snakemake goes by the input's mtime, so this re-makes every output
            # made from it (not only this one), and lets the start-of-run check pass
            remake = f"touch {root.input} && {SNAKEMAKE} {self.output}"
        elif root is self:
            remake = f"{SNAKEMAKE} -f {self.output}"
        else:
            remake = f"{SNAKEMAKE} -f {root.output} && {SNAKEMAKE} {self.output}"
        if self.problem in ("changed", "missing input"):
            digests = f"sha256 recorded {_short(self.recorded)}" + (
                f", now {_short(self.now)}" if self.problem == "changed" else ""
            )
            return f"{self.output}: {self.summary()} ({digests}): re-make it with {remake}"
        return f"{self.output}: {self.summary()}: re-make it with {remake}"


def _short(digest: str | None) -> str:
    return f"{digest[:SHOWN_HEX]}…" if digest else "nothing"


class Hashes:
    """sha256 of files, each read once (streamed) per size and mtime: one audit of a folder
    hashes a capture that forty outputs were made from once. Kept for one call only, unlike
    :func:`selfsense.io.provenance.sha256`'s cache, which lasts the process: a file replaced
    with the same size and mtime would look unchanged to it."""

    def __init__(self, block: int = 1 << 20):
        self.block = block
        self._seen: dict[tuple[str, int, int], str] = {}

    def __call__(self, path: Path, st: os.stat_result | None = None) -> str:
        st = st or path.stat()
        key = (os.fspath(path.resolve()), st.st_size, st.st_mtime_ns)
        if key not in self._seen:
            self._seen[key] = file_sha256(path, self.block)
        return self._seen[key]


def sidecar_of(output: Path) -> Path:
    """Where ``output``'s provenance is: ``<output>.json``, or the PNG's for a figure's PDF, or
    the JSON report itself when it carries its provenance (QC reports, models, stats)."""
    side = output.with_name(output.name + ".json")
    if not side.exists() and output.suffix == ".pdf":
        png = output.with_suffix(".png.json")
        side = png if png.exists() else side
    if not side.exists() and output.suffix == ".json" and output.exists():
        return output
    return side


def read_provenance(output: Path) -> dict[str, Any]:
    """The provenance recorded for ``output`` (its ``inputs`` map path → sha256 at least)."""
    side = sidecar_of(output)
    try:
        doc = json.loads(side.read_text())
    except FileNotFoundError:
        raise ProvenanceError(f"no provenance ({side} is missing)") from None
    except (OSError, UnicodeDecodeError, ValueError) as err:
        reason = " ".join(str(err).split())
        raise ProvenanceError(f"provenance {side} is not readable JSON ({reason})") from None
    if side == output:  # a report with its provenance inside
        doc = doc.get("provenance") if isinstance(doc, dict) else None
    inputs = doc.get("inputs") if isinstance(doc, dict) else None
    if not isinstance(inputs, dict) or not all(isinstance(v, str) for v in inputs.values()):
        raise ProvenanceError(f"provenance {side} records no inputs with their sha256")
    return doc


def audit(
    output: str | os.PathLike, root: str | os.PathLike | None = None, hashes: Hashes | None = None
) -> list[Stale]:
    """What of ``output``'s recorded inputs differs from now, or is gone, or was made by the
    workflow and is stale itself (empty: up to date).

    Inputs are recorded as the rules named them, relative to the checkout the workflow ran in:
    ``root`` (default: the current directory). Every input is hashed whole, whatever its mtime,
    so a replacement that kept size and mtime is found too; ``hashes`` shares the reading
    between calls.
    """
    return Auditor(root, hashes)(Path(output))[0]


class Auditor:
    """Audits outputs with one :class:`Hashes` and a memory of the outputs already audited, so
    that an input made by the workflow (a QC report, a model) is audited once, whether it is
    named or found as an input of another output."""

    def __init__(self, root: str | os.PathLike | None = None, hashes: Hashes | None = None):
        self.root = Path(root or ".")
        self.hashes = hashes or Hashes()
        self._done: dict[str, tuple[list[Stale], int]] = {}

    def __call__(self, output: Path) -> tuple[list[Stale], int]:
        """The reasons ``output`` is stale, and how many inputs it records."""
        key = os.path.abspath(output)
        if key not in self._done:
            self._done[key] = ([], 0)  # an output among its own inputs' inputs: no loop
            self._done[key] = self._audit(output)
        return self._done[key]

    def _audit(self, output: Path) -> tuple[list[Stale], int]:
        name = str(output)
        try:
            doc = read_provenance(output)
        except ProvenanceError as err:
            return [Stale(name, "no provenance", detail=str(err))], 0
        stale = [] if output.exists() else [Stale(name, "missing output")]
        for recorded_path, recorded in sorted(doc["inputs"].items()):
            path = self.root / recorded_path
            try:
                now = self.hashes(path)
            except FileNotFoundError:
                stale.append(Stale(name, "missing input", recorded_path, recorded))
                continue
            except OSError as err:  # unreadable (permissions, a directory): not what was recorded
                why = f"input {recorded_path} cannot be read ({type(err).__name__}: {err.strerror})"
                stale.append(Stale(name, "unreadable input", recorded_path, recorded, detail=why))
                continue
            if now != recorded:
                stale.append(Stale(name, "changed", recorded_path, recorded, now))
            elif _has_provenance(path) and (made_from := self(path)[0]):
                stale.append(Stale(name, "stale input", recorded_path, cause=made_from[0]))
        return stale, len(doc["inputs"])


def _has_provenance(path: Path) -> bool:
    """Whether ``path`` was made by the workflow with provenance (a sidecar, or a JSON report
    that carries it)."""
    if path.with_name(path.name + ".json").exists():
        return True
    doc = _read(path) if path.suffix == ".json" else None
    return isinstance(doc, dict) and isinstance(doc.get("provenance"), dict)


def outputs_in(folder: Path) -> Iterator[Path]:
    """Every output under ``folder`` with provenance: the file beside each ``<output>.json``
    sidecar, and each JSON report that carries its own (or that cannot be read: it is reported).
    Hidden files (atomic_path's temporaries) are not outputs."""
    for side in sorted(folder.rglob("*.json")):
        if side.name.startswith("."):
            continue
        target = side.with_name(side.name[: -len(".json")])
        if target.exists() or _is_sidecar(side):
            yield target
        elif _carries_provenance(side):
            yield side


def _read(path: Path) -> Any:
    try:
        return json.loads(path.read_text())
    except (OSError, UnicodeDecodeError, ValueError):
        return None


def _is_sidecar(path: Path) -> bool:
    doc = _read(path)
    return isinstance(doc, dict) and "inputs" in doc and "code" in doc


def _carries_provenance(path: Path) -> bool:
    doc = _read(path)
    return doc is None or (isinstance(doc, dict) and isinstance(doc.get("provenance"), dict))


def report(
    paths: Iterable[str | os.PathLike], root: str | os.PathLike | None = None
) -> tuple[list[str], bool]:
    """``selfsense audit``'s lines for outputs and folders of outputs, and whether any is stale.

    A line per stale input (or unreadable provenance), or ``<output>: up to date (<n> inputs)``;
    each distinct input is read once for the whole call."""
    auditor, lines, stale_any = Auditor(root), [], False
    for given in map(Path, paths):
        if given.is_dir():
            targets = list(outputs_in(given))
            if not targets:
                lines.append(f"{given}: no outputs with provenance in this folder")
                stale_any = True
        elif given.suffix == ".json" and _is_sidecar(given):
            targets = [given.with_name(given.name[: -len(".json")])]  # the sidecar was named
        else:
            targets = [given]
        for output in targets:
            stale, n = auditor(output)
            stale_any = stale_any or bool(stale)
            lines += [s.line() for s in stale] or [
                f"{output}: up to date ({n} input{'' if n == 1 else 's'})"
            ]
    return lines, stale_any


def check_inputs_unchanged(
    datasets: Iterable[str], results_dir: str | os.PathLike = "results"
) -> None:
    """Stop (:class:`StaleInput`, one line) if an input of a measured dataset's QC report
    (``results/<dataset>/qc/<experiment>.json``: the capture) or of its stage plan
    (``results/<dataset>/stages.csv.json``: the manifest, which the QC reports hold only as an
    ancient input, so that a new batch does not re-check the earlier captures) no longer has the
    content the report checked, yet is not newer than the report, so that Snakemake would
    re-make nothing from it. Run at every start of the workflow, so it must cost nothing
    measurable: an input whose size and mtime are those recorded is taken as unchanged without
    reading it (a replacement that kept both is found only by ``selfsense audit``); one whose
    size differs is changed; one whose mtime alone differs is hashed. Reports made before sizes
    and mtimes were recorded are skipped. Nothing is written or touched.
    """
    found: dict[str, tuple[Path, str]] = {}  # the manifest is an input of every report
    hashes = Hashes()
    for dataset in datasets:
        folder = Path(results_dir) / dataset
        for qc in [*sorted((folder / "qc").glob("*.json")), folder / "stages.csv.json"]:
            doc = _read(qc)
            # a QC report holds its provenance under a key; a table's sidecar is one
            prov = doc.get("provenance", doc) if isinstance(doc, dict) else None
            if not isinstance(prov, dict) or not isinstance(prov.get("input_files"), dict):
                continue  # not a QC report (captures.csv.json), or an old one: audit checks it
            made = qc.stat().st_mtime_ns
            for path, seen in sorted(prov["input_files"].items()):
                if path in found or not isinstance(seen, dict):
                    continue
                try:
                    st = os.stat(path)
                except OSError:
                    continue  # gone: Snakemake says so itself
                if st.st_mtime_ns > made:
                    continue  # newer than the report: Snakemake re-makes it
                was = (seen.get("size"), seen.get("mtime_ns"))
                if was == (st.st_size, st.st_mtime_ns):
                    continue
                if was[0] != st.st_size:
                    found[path] = (qc, f"size {was[0]} bytes recorded, now {st.st_size}")
                elif (now := hashes(Path(path), st)) != prov["inputs"].get(path):
                    found[path] = (qc, f"same size, other mtime, sha256 now {_short(now)}")
                # else: the same bytes with another mtime (a copy)
    if found:
        (path, (qc, why)), *rest = found.items()
        more = f" (and {len(rest)} more: {', '.join(r[0] for r in rest)})" if rest else ""
        raise StaleInput(
            f"{path}{more}: not the file {qc} checked ({why}), yet not newer than it (replaced "
            "with cp -p, rsync -t or tar x?), so nothing made from it would be re-made: "
            f"touch {' '.join(found)} and run again "
            f"(selfsense audit {qc.parent.parent} lists what is stale)"
        )
