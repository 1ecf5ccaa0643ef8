"""The import's reader of NI TDMS files (``nptdms``), streamed in chunks of the requested
channels, as the CSV reader streams.

A channel is ``Group/Channel`` (names as the file has them, spaces and further '/' included: the
split that names an existing group and channel is taken; nptdms' own path form
``/'Group'/'Channel'`` works too), its channel name alone when no other group has one so named, or
its position among the file's channels counted from 1 (groups in file order). Every requested
channel is located and its type checked when the file is opened (nothing is read yet): a wrong
name, a complex, logical, timestamp or text channel, or channels of different lengths stop with
one line naming the file and the channel before a pass begins.

A channel's ``wf_increment`` property (LabVIEW's waveform Δt) declares fs = 1/wf_increment: the
import uses it when neither --time nor --fs is given, else they must agree with it
(:data:`~selfsense.io.sources.DECLARED_FS_RTOL`), as the requested channels' must among
themselves.

A file whose last segment ends before its data do (a write interrupted) is cut to the samples
every requested channel holds, and :attr:`TdmsSource.note` says so: TDMS has no fill value, so
nptdms reads only what the file holds and no sample is made up.
"""

from __future__ import annotations

import logging
import math
import re
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np

from selfsense.io.sources import (
    CHUNK_ROWS,
    DECLARED_FS_RTOL,
    Column,
    ImportProblem,
    column_spans,
    listed,
    one_column_each,
    one_length,
    short_error,
    source_labels,
)

#: nptdms' path of a channel, /'Group'/'Channel' (a quote in a name doubled)
TDMS_PATH = re.compile(r"/'((?:[^']|'')*)'/'((?:[^']|'')*)'")


class TdmsSource:
    """The requested channels of a TDMS file, read in chunks by ``read_data(offset, length)``."""

    kind = "TDMS"
    rows = "samples"

    def __init__(self, path: Path, columns: Sequence[Column]):
        self.path = path
        with open(path, "rb") as raw:
            lead_in = raw.read(4)
        if lead_in != b"TDSm":  # nptdms reads any other file as one without channels
            raise ImportProblem(
                f"{path}: not a TDMS file (it does not begin with a TDMS segment, 'TDSm')"
            )
        with self._open() as tdms:
            self.channels = [(g.name, ch.name) for g in tdms.groups() for ch in g.channels()]
            if not self.channels:
                raise ImportProblem(f"{path}: the TDMS file has no channels")
            self.where = {c.name: self._locate(c) for c in columns}
            self.labels = source_labels(
                columns, lambda c: f"channel {self.spelled(self.where[c.name])!r}"
            )
            objects = {name: tdms[g][ch] for name, (g, ch) in self.where.items()}
            for name, channel in objects.items():
                self._check_type(name, channel)
            one_column_each(path, self.labels, self.where, "channel")
            lengths = {name: len(channel) for name, channel in objects.items()}
            empty = [name for name, n in lengths.items() if n == 0]
            if empty and len(empty) < len(lengths):
                raise ImportProblem(
                    f"{path}: {self.labels[empty[0]]} holds no data (the file lists it without "
                    "values)"
                )
            self.declared_fs = self._declared_fs(
                {n: ch for n, ch in objects.items() if n != "time"}
            )
            self.note = ""
            segments = tdms._reader._segments  # nptdms has no public word on a cut segment
            if segments and segments[-1].segment_incomplete:
                lengths, self.note = self._cut(lengths)
        self.n = one_length(path, "channels", self.labels, lengths)
        if self.n == 0:
            raise ImportProblem(f"{path}: no data (the channels are empty)")

    @contextmanager
    def _open(self) -> Iterator[Any]:
        """The file opened for streaming; a damaged one (nptdms raises what it meets) or a read
        that fails is one line. nptdms' own warnings are held back: of a cut segment, the
        import's note says it once."""
        from nptdms import TdmsFile
        from nptdms.log import log_manager

        level = log_manager.log_level
        log_manager.set_level(logging.ERROR)
        try:
            try:
                tdms = TdmsFile.open(self.path)
            except Exception as err:  # noqa: BLE001 - nptdms raises whatever a damaged file gives
                raise ImportProblem(
                    f"{self.path}: not a readable TDMS file ({short_error(err)})"
                ) from None
            with tdms:
                yield tdms
        except ImportProblem:
            raise
        except (OSError, ValueError, KeyError, IndexError, EOFError) as err:
            raise ImportProblem(
                f"{self.path}: not a readable TDMS file ({short_error(err)})"
            ) from None
        finally:
            log_manager.set_level(level)

    def _cut(self, lengths: dict[str, int]) -> tuple[dict[str, int], str]:
        """The lengths of a file whose last segment ends before its data do (a write
        interrupted: LabVIEW stopped, the disk filled, the file copied while logging): nptdms
        reads only the values the file holds, so the requested channels are cut to the samples
        they all hold, and the capture says so. No value is made up: TDMS has no fill."""
        n = min(lengths.values())
        each = ", ".join(f"{self.labels[k]}: {m}" for k, m in lengths.items())
        return {k: n for k in lengths}, (
            f"the file's last segment is incomplete (its write was interrupted): imported the {n} "
            f"samples every channel holds ({each})"
        )

    @staticmethod
    def spelled(where: tuple[str, str]) -> str:
        return f"{where[0]}/{where[1]}"

    def _shown(self) -> str:
        return listed([f"{k} {self.spelled(w)!r}" for k, w in enumerate(self.channels, 1)])

    def _locate(self, c: Column) -> tuple[str, str]:
        if isinstance(c.source, int):
            if not 1 <= c.source <= len(self.channels):
                raise ImportProblem(
                    f"{self.path}: channel {c.source} for {c.name} does not exist (the file has "
                    f"{len(self.channels)} channels, counted from 1: {self._shown()})"
                )
            return self.channels[c.source - 1]
        text = c.source.strip()
        if len(text) > 1 and text[0] == text[-1] and text[0] in "'\"":
            text = text[1:-1]  # quotes typed inside the shell's
        path = TDMS_PATH.fullmatch(text)
        if path:
            wanted = (path.group(1).replace("''", "'"), path.group(2).replace("''", "'"))
            found = [w for w in self.channels if w == wanted]
        else:
            found = [w for w in self.channels if self.spelled(w) == text]
            found = found or [w for w in self.channels if w[1] == text]
        if len(found) > 1:
            groups = ", ".join(repr(g) for g, _ in found[:5])
            raise ImportProblem(
                f"{self.path}: channel {text!r} for {c.name} is in the groups {groups}: type "
                f"{Column(c.name, self.spelled(found[0]), c.unit).typed()} (Group/Channel)"
            )
        if not found:
            raise ImportProblem(
                f"{self.path}: no channel {text!r} for {c.name} (Group/Channel, or a position "
                f"counted from 1: {self._shown()})"
            )
        return found[0]

    def _check_type(self, name: str, channel: Any) -> None:
        dtype = channel.dtype
        label = self.labels[name]
        if dtype is None or len(channel) == 0:
            return  # an empty channel: the lengths say so
        dtype = np.dtype(dtype)
        if np.issubdtype(dtype, np.complexfloating):
            raise ImportProblem(
                f"{self.path}: {label} is complex: log its real part, magnitude or phase instead"
            )
        if dtype == np.bool_:
            raise ImportProblem(f"{self.path}: {label} is logical (true/false), not numbers")
        if np.issubdtype(dtype, np.datetime64):
            raise ImportProblem(
                f"{self.path}: {label} holds timestamps, not numbers: leave --time out (the "
                "channels' wf_increment, or --fs, gives the rate)"
            )
        if dtype.kind not in "iuf":
            raise ImportProblem(f"{self.path}: {label} is not numeric ({dtype})")

    def _declared_fs(self, objects: dict[str, Any]) -> tuple[float, str] | None:
        """fs = 1/wf_increment of the requested channels (one clock: all that declare one agree),
        None if none declares a positive, finite one."""
        declared = []
        for name, channel in objects.items():
            try:
                step = float(channel.properties.get("wf_increment"))
            except (TypeError, ValueError):
                continue
            if math.isfinite(step) and step > 0:
                declared.append((float(f"{1 / step:.12g}"), step, self.where[name]))
        if not declared:
            return None
        fs, step, where = declared[0]
        for other, other_step, other_where in declared[1:]:
            if not math.isclose(other, fs, rel_tol=DECLARED_FS_RTOL):
                raise ImportProblem(
                    f"{self.path}: channels {self.spelled(where)!r} and "
                    f"{self.spelled(other_where)!r} were sampled at different rates "
                    f"(wf_increment {step:g} s and {other_step:g} s): import them separately"
                )
        return fs, f"wf_increment of channel {self.spelled(where)!r} ({step:g} s)"

    def chunks(self, progress: bool = False) -> Iterator[tuple[int, dict[str, np.ndarray]]]:
        with self._open() as tdms:
            objects = {name: tdms[g][ch] for name, (g, ch) in self.where.items()}
            for start in range(0, self.n, CHUNK_ROWS):
                length = min(CHUNK_ROWS, self.n - start)
                yield (
                    start,
                    {
                        name: np.asarray(ch.read_data(start, length), dtype=np.float64)
                        for name, ch in objects.items()
                    },
                )

    def varying(self, name: str) -> str:
        """For the refusal of a constant channel: the file's numeric channels that vary."""
        skip = {self.where.get("time"), self.where[name]}
        vary = []
        with self._open() as tdms:
            for k, where in enumerate(self.channels, start=1):
                channel = tdms[where[0]][where[1]]
                dtype = channel.dtype
                if where in skip or dtype is None or np.dtype(dtype).kind not in "iuf":
                    continue
                lo, hi = math.inf, -math.inf
                for start in range(0, len(channel), CHUNK_ROWS):
                    values = np.asarray(channel.read_data(start, CHUNK_ROWS), dtype=np.float64)
                    a, b = column_spans(values[:, None])
                    lo, hi = min(lo, float(a[0])), max(hi, float(b[0]))
                if lo < hi:
                    vary.append(f"{k} {self.spelled(where)!r}")
        if not vary:
            return "no other channel of the file varies"
        return f"channels are counted from 1: the channels that vary are {listed(vary)}"
