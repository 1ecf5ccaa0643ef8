"""The raw-capture contract: one netCDF4 file per DAQ run (docs/design.md, "The capture contract").

This is the only module that reads or writes captures. Channels are stored as the DAQ records
them, packed 16-bit integers (``scale_factor``/``add_offset``, CF conventions) chunked along
``time``; every reader streams them in chunks so memory never grows with capture length.
A simulated capture also carries a ``/truth`` group (true parameters and noiseless states) that
analyses never read; only tests and the scorecard's parameter-recovery section do.

Every failure raises :class:`CaptureError` whose message is one line that starts with the file.

**Missing samples** (CF §2.5.1). A channel's sample is missing (NaN once unpacked, counted under
``nan`` in the QC report, never as clipped) when its int16 code is the contract's
:data:`FILL` (−32768, outside the ±INT16_FULL full scale), the channel's own ``_FillValue`` (or,
when it declares none, netCDF's default int16 fill −32767, which netCDF4-python masks too), or one
of its ``missing_value`` codes (a scalar or a vector, in the packed domain). The codes are read
once per channel on open; a channel that declares no code besides FILL (every capture the
:class:`CaptureWriter` makes, whose ``_FillValue`` is FILL) costs no extra comparison.

**Minimum length**, stated here once. Every capture holds at least :data:`MIN_SAMPLES` samples on a
time axis that advances by 1/fs per sample (:func:`open_capture` checks the length and both ends,
streaming checks every sample in between: so check_capture and every analysis). An analysis that
needs more says so where it opens the capture, ``open_capture(..., min_samples=, purpose=)``, or,
when its minimum depends on the capture's attributes, :meth:`Capture.require_samples`:

- ripple extraction (Eq 3.6–3.13): one Fourier window, ``SamplingPlan.block_len`` = np·ns samples
  (48 at the thesis's np = 4, ns = 12);
- characterise: one whole drive cycle at the least, :data:`CHARACTERISE_MIN_SAMPLES` (its loop
  width needs 16 samples rising and 16 falling), and a drive U that varies
  (:meth:`Capture.require_varying`, after the pass: a constant U has no stroke to divide by).
"""

from __future__ import annotations

import errno
import logging
import math
import os
import shutil
import time
import zlib
from collections.abc import Iterator, Mapping, Sequence
from contextlib import contextmanager, suppress
from contextvars import ContextVar
from dataclasses import asdict, dataclass, field
from pathlib import Path

import netCDF4
import numpy as np

from selfsense.io.provenance import WRITE_ERRNO, provenance, temporary_path, write_json

LOG = logging.getLogger("selfsense.io.capture")

#: int16 code reserved for missing samples (NaN); the ADC range maps onto ±INT16_FULL.
FILL = np.int16(-32768)
INT16_FULL = 32767
CONVENTIONS = "CF-1.8"
#: relative tolerance on fs against the folding equation and on the time axis
FS_RTOL = 1e-6
#: per-variable chunk cache [bytes]. netCDF-C's default (64 MB per variable) only pays off for
#: random access; captures are streamed in order, so a few chunks per variable suffice and a
#: capture's memory stays flat however long it is (benchmarks/README.md, "Streaming memory").
CHUNK_CACHE_BYTES = 1 << 20
#: long writes and streamed reads log their progress this often (fraction of the samples)
PROGRESS_STEP = 0.1
#: the compressions a capture's channels may use (None: uncompressed): netCDF-C 4.9+ reads them
#: with the filter plugins it ships, as the pinned netCDF4 wheel does. CaptureWriter stores any
#: data with zlib level 1; the twin writes with TWIN_COMPRESSION, which keeps zlib's size at twice
#: its speed on the twin's captures (docs/capture-contract.md)
COMPRESSIONS = ("zlib", "zstd", "blosc_lz4", "blosc_zstd")
TWIN_COMPRESSION = ("blosc_zstd", 3)
#: chunks smaller than this are never stored with blosc (see _filters)
BLOSC_MIN_CHUNK_BYTES = 4096
#: the fewest samples of any capture: a time axis with one step, so that fs can be checked
MIN_SAMPLES = 2
#: the fewest samples characterise takes: one drive cycle at the coarsest, 16 samples rising and
#: 16 falling (the loop width's branches, selfsense.chapters.characterise)
CHARACTERISE_MIN_SAMPLES = 32
#: bounds on a channel's packing: one ADC step at least MIN_SCALE and the full scale
#: |add_offset| + INT16_FULL·scale_factor at most MAX_FULL_SCALE (in the channel's SI unit), so
#: that squares and products of samples (powers, variances, fits) stay finite, normal float64
MIN_SCALE = 1e-30
MAX_FULL_SCALE = 1e30
#: netCDF's default fill of int16, missing where a channel declares no _FillValue
NC_DEFAULT_FILL_I2 = int(netCDF4.default_fillvals["i2"])


class CaptureError(ValueError):
    """A capture that breaks the contract; the message is one line naming the file."""


class UnshrinkableChunk(CaptureError):
    """HDF5's blosc filter failed on a chunk it could not shrink (noise-like data): the capture
    was not written; zlib stores any data."""


class CaptureWriteError(CaptureError):
    """The capture's folder cannot take it (no space, read-only, a name too long): writing it again
    with another compression would fail the same way."""


@dataclass(frozen=True)
class ChannelSpec:
    """One DAQ channel: its CF units and the ADC full-scale range it is packed into."""

    name: str
    units: str
    long_name: str
    lo: float
    hi: float
    dim: str = "time"
    bits: int = 16  # the ADC's resolution; its codes are stored as int16 all the same

    @property
    def scale_factor(self) -> float:
        return (self.hi - self.lo) / (2 * INT16_FULL)

    @property
    def step(self) -> float:
        """The ADC's quantisation step: 2^(16 − bits) int16 codes."""
        return self.scale_factor * 2 ** (16 - self.bits)

    @property
    def full_code(self) -> int:
        """The ADC's largest code, in its steps."""
        return INT16_FULL >> (16 - self.bits)

    @property
    def add_offset(self) -> float:
        return 0.5 * (self.hi + self.lo)

    def pack(self, values: np.ndarray) -> tuple[np.ndarray, int]:
        """Quantise to int16 as a 16-bit ADC does; returns codes and the count clipped."""
        codes = np.rint(
            (np.asarray(values, dtype=np.float64) - self.add_offset) / self.scale_factor
        )
        clipped = int(np.count_nonzero(np.abs(codes) > INT16_FULL))  # NaN compares false
        nan = np.isnan(codes)
        if nan.any():  # NaN has no int16 value: FILL stands for it
            codes[nan] = 0
            packed = np.clip(codes, -INT16_FULL, INT16_FULL, out=codes).astype(np.int16)
            packed[nan] = FILL
            return packed, clipped
        return np.clip(codes, -INT16_FULL, INT16_FULL, out=codes).astype(np.int16), clipped

    def quantize(self, values: np.ndarray) -> np.ndarray:
        """The values as the ADC reports them: on its grid of :attr:`step`, clipped to range,
        NaN kept.

        For a 16-bit ADC equal to unpacking :meth:`pack`'s codes, without the int16 round trip:
        the closed-loop twin calls it for every 12-sample block (hence two ufuncs rather than
        np.clip, whose dispatch costs more than the arithmetic on 12 samples; both keep NaN).
        """
        step, offset, full = self.step, self.add_offset, self.full_code
        codes = np.rint((np.asarray(values, dtype=np.float64) - offset) / step)
        return np.minimum(np.maximum(codes, -full), full) * step + offset


#: Units and meaning of every channel the bench can record (docs/design.md). Ranges are the
#: instrument's; the manifest may override them.
CHANNEL_UNITS: dict[str, tuple[str, str]] = {
    "U": ("V", "drive voltage at the actuator (1:100 divider undone)"),
    "I": ("A", "drive current from the current probe"),
    "Ur": ("V", "ripple voltage after the high-pass filter"),
    "Ir": ("A", "ripple current after the high-pass filter"),
    "x_laser": ("m", "position from the laser vibrometer"),
    "F": ("N", "force between stack and base"),
    "T_top": ("degC", "surface temperature, top IR thermometer"),
    "T_mid": ("degC", "surface temperature, middle IR thermometer"),
    "T_bot": ("degC", "surface temperature, bottom IR thermometer"),
    "x_ref": ("m", "reference position of the real-time controller"),
    "x_hpo_rt": ("m", "real-time hybrid position observer estimate"),
    "u_cmd": ("V", "voltage command of the real-time controller"),
    "i_cmd": ("A", "current command of the current-drive amplifier"),
    "x_disp": ("m", "position from the displacement sensor"),
}
SLOW_CHANNELS = frozenset({"T_top", "T_mid", "T_bot"})
#: displacement channels of the contract, in order of preference
DISPLACEMENT = ("x_laser", "x_disp")


def channel_spec(name: str, lo: float, hi: float, bits: int = 16) -> ChannelSpec:
    units, long_name = CHANNEL_UNITS[name]
    return ChannelSpec(
        name, units, long_name, lo, hi, "time_slow" if name in SLOW_CHANNELS else "time", bits
    )


def folded_fs(fr: float, ns: int, nf: int) -> float:
    """Sampling frequency that folds ripple fr onto fs/ns after nf folds (Eq 3.4, Eq 3.5)."""
    if nf % 2 == 0:
        return 2 * ns * fr / (nf * ns + 2)
    return 2 * ns * fr / ((nf + 1) * ns - 2)


def _fail(path: os.PathLike | str, problem: str) -> CaptureError:
    return CaptureError(f"{path}: {problem}")


class _Progress:
    """Logs "k % of n samples …, rate" every PROGRESS_STEP of n, so that `tail -f` on a long
    rule's log shows it moving."""

    def __init__(self, what: str, total: int):
        self.what, self.total = what, max(int(total), 1)
        self.start = time.monotonic()
        self.next = PROGRESS_STEP

    def __call__(self, done: int) -> None:
        if done / self.total + 1e-12 < self.next:
            return
        elapsed = max(time.monotonic() - self.start, 1e-9)
        LOG.info(
            "%s: %3.0f %% of %d samples (%.3g M samples/s)",
            self.what,
            100 * done / self.total,
            self.total,
            done / elapsed / 1e6,
        )
        self.next = (math.floor(done / self.total / PROGRESS_STEP + 1e-9) + 1) * PROGRESS_STEP


#: chunks a variable's values are queued for before one call writes them (CaptureWriter._put)
WRITE_BLOCKS = 8
#: set inside :func:`scratch_captures`: the captures written are a member's scratch
_SCRATCH: ContextVar[bool] = ContextVar("scratch_captures", default=False)
#: a scratch capture's codec in place of a blosc one: lossless as every codec of the contract,
#: cheaper than the twin's level 3, and one that shrinks a chunk of noise (blosc_lz4 does not,
#: and blosc refuses a chunk it cannot shrink)
SCRATCH_COMPRESSION = ("blosc_zstd", 1)


@contextmanager
def scratch_captures() -> Iterator[None]:
    """Captures written inside are one in-process member's scratch, gone when the member is
    (:mod:`selfsense.envelope.member`): written with :data:`SCRATCH_COMPRESSION` in place of a
    blosc codec, and not read back. Their codes, scales and attributes are those of the same
    capture written to raw/ (the codecs are lossless), so a reader gets the same numbers; the
    read-back guards a capture kept on a storage medium, which a scratch capture, read once by
    the next steps, is not."""
    token = _SCRATCH.set(True)
    try:
        yield
    finally:
        _SCRATCH.reset(token)


class CaptureWriter:
    """Write a capture sequentially in chunks; the file appears only when complete and verified.

    Data go to a temporary beside ``path`` that no other writer uses
    (:func:`~selfsense.io.provenance.temporary_path`). On a clean exit of the ``with`` block the
    temporary is read back whole and compared, variable by variable, with a CRC-32 of what was
    written (a check against storage and transfer errors, like HDF5's Fletcher-32, at ten times
    blake2b's speed, which took 8 % of a simulation); only then is it renamed over
    ``path``. An interrupted or concurrent run therefore
    never leaves a file that looks complete, and every chunk carries a Fletcher-32 checksum so
    a capture damaged later fails on read (its QC) instead of giving numbers.

    The read-back costs about a tenth of a simulated capture's CPU (measured 2026-12-01: 10 s of
    capture 0.173 s without it against 0.193 s) and stays. A CRC of the arrays as they are written
    alone would check nothing, and HDF5's Fletcher-32 (taken before the compression, checked after
    it on every read) only makes a later read fail: without the read-back a capture whose chunks
    did not reach the disk as written would still be renamed into place under its name, with a
    QC report counting codes the file does not hold, and a chunk HDF5 never stored reads back as
    fill, which no checksum flags. The capture in place is the capture that was checked only
    because it was read back before the rename.
    """

    def __init__(
        self,
        path: os.PathLike | str,
        attrs: Mapping[str, object],
        channels: Sequence[ChannelSpec],
        n_samples: int,
        n_slow: int = 0,
        fs_slow: float | None = None,
        chunk_len: int = 1 << 16,
        compression: str | None = "zlib",
        complevel: int = 1,
        truth: Sequence[str] = (),
        truth_decimation: int = 1,
    ):
        self.path = Path(path)
        self.tmp: Path | None = None
        self.channels = {c.name: c for c in channels}
        self.n_samples = int(n_samples)
        self.n_slow = int(n_slow)
        self.clipped = dict.fromkeys(self.channels, 0)
        self._pos = {"time": 0, "time_slow": 0, "time_truth": 0}
        self.truth = tuple(truth)
        self.truth_decimation = int(truth_decimation)
        self._attrs = dict(attrs)
        self._rate = {"time": float(attrs["fs"]), "time_slow": fs_slow}
        self._chunk_len = chunk_len
        self._scratch = _SCRATCH.get()
        blosc = self._scratch and compression is not None and compression.startswith("blosc")
        self._compression = SCRATCH_COMPRESSION if blosc else (compression, complevel)
        self.stats = ChunkStats()
        self._nc: netCDF4.Dataset | None = None
        self._crc: dict[str, int] = {}
        # per variable: [first index, arrays not yet written, how many values they hold]
        self._queued: dict[str, list] = {}
        self._progress = _Progress(f"{self.path} written", self.n_samples)
        self._seconds = {
            "packing and writing": 0.0,
            "reading back": 0.0,
        }  # logged: benchmarks/run.py's shares

    def __enter__(self) -> CaptureWriter:
        try:
            self.tmp = temporary_path(self.path)
            # created here first: the OS's errno names the cause, where netCDF-C reports any
            # failed create (no space, read-only, a name too long) as "Permission denied"
            os.close(os.open(self.tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666))
        except OSError as err:
            raise _cannot_write(self.path, err, self.tmp) from None
        try:
            nc = netCDF4.Dataset(self.tmp, "w", format="NETCDF4")
        except OSError as err:
            cause = _no_room(self.tmp, self._room())
            _remove(self.tmp)
            if cause is not None:
                raise _cannot_write(self.path, cause, self.tmp) from None
            # the folder took the file and has room: netCDF-C's errno says nothing here
            raise CaptureWriteError(
                f"{self.path}: cannot write the capture: HDF5 could not create it "
                f"({err.strerror or err}) in a folder that is writable and has room "
                f"(file locking on a network file system? HDF5_USE_FILE_LOCKING=FALSE)"
            ) from None
        try:
            self._define(nc)
        except BaseException:
            nc.close()
            _remove(self.tmp)
            raise
        self._nc = nc
        return self

    def _room(self) -> int:
        """Bytes the file must be able to grow by for a failed write not to be a full disk: HDF5
        writes chunk by chunk, so the largest chunk (the f8 time axis's), and 64 KiB of
        metadata."""
        return 8 * max(1, min(self._chunk_len, max(self.n_samples, self.n_slow))) + (1 << 16)

    def _define(self, nc: netCDF4.Dataset) -> None:
        nc.setncatts({k: _attr(v) for k, v in self._attrs.items()})
        nc.Conventions = CONVENTIONS
        nc.createDimension("time", self.n_samples)
        self._time_var(nc, "time", self.n_samples)
        if self.n_slow:
            nc.createDimension("time_slow", self.n_slow)
            self._time_var(nc, "time_slow", self.n_slow)
        for spec in self.channels.values():
            n = self.n_samples if spec.dim == "time" else self.n_slow
            chunk = max(1, min(self._chunk_len, n))
            v = nc.createVariable(
                spec.name,
                "i2",
                (spec.dim,),
                **_filters(*self._compression, 2 * chunk),
                chunksizes=(chunk,),
                fill_value=FILL,
            )
            v.set_auto_maskandscale(False)
            v.setncatts(
                {
                    "units": spec.units,
                    "long_name": spec.long_name,
                    "scale_factor": spec.scale_factor,
                    "add_offset": spec.add_offset,
                    "valid_min": np.int16(-INT16_FULL),
                    "valid_max": np.int16(INT16_FULL),
                }
            )
        if self.truth:
            g = nc.createGroup("truth")
            g.decimation = self.truth_decimation
            n_truth = -(-self.n_samples // self.truth_decimation)
            g.createDimension("time_truth", n_truth)
            for name in self.truth:
                chunk = max(1, min(self._chunk_len, n_truth))
                g.createVariable(
                    name,
                    "f4",
                    ("time_truth",),
                    **_filters(*self._compression, 4 * chunk),
                    chunksizes=(chunk,),
                )
        _limit_chunk_cache(nc)

    def _time_var(self, nc: netCDF4.Dataset, dim: str, n: int) -> None:
        chunk = max(1, min(self._chunk_len, n))
        v = nc.createVariable(
            dim, "f8", (dim,), **_filters(*self._compression, 8 * chunk), chunksizes=(chunk,)
        )
        v.units = "s"
        v.standard_name = "time"
        v.sampling_rate = float(self._rate[dim])

    def write(self, data: Mapping[str, np.ndarray], dim: str = "time") -> None:
        """Append the next chunk of every channel on ``dim`` (all of equal length)."""
        assert self._nc is not None, "use CaptureWriter inside a with block"
        lengths = {len(v) for v in data.values()}
        if len(lengths) != 1:
            raise ValueError(f"{self.path}: chunk channels differ in length {sorted(lengths)}")
        n = lengths.pop()
        start = self._pos[dim]
        self._pos[dim] = start + n
        if dim == "time_truth":
            began = time.perf_counter()
            for name, values in data.items():
                self._put(f"truth/{name}", start, np.asarray(values, dtype=np.float32))
            self._seconds["packing and writing"] += time.perf_counter() - began
            return
        began = time.perf_counter()
        self._put(dim, start, (start + np.arange(n)) / self._rate[dim])
        for name, values in data.items():
            codes, clipped = self.channels[name].pack(values)
            self.clipped[name] += clipped
            self.stats.add(name, codes)
            self._put(name, start, codes)
        self._seconds["packing and writing"] += time.perf_counter() - began
        if dim == "time":
            self._progress(start + n)

    def _put(self, name: str, start: int, values: np.ndarray) -> None:
        """Queue one variable's next values (the writer appends sequentially); they reach HDF5
        :data:`WRITE_BLOCKS` chunks at a time, since each call into netCDF4 costs about 0.1 ms
        whatever its size (a tenth of a simulated capture's writing at one chunk a call)."""
        queued = self._queued.setdefault(name, [start, [], 0])
        queued[1].append(values)
        queued[2] += len(values)
        if queued[2] >= WRITE_BLOCKS * self._chunk_len:
            self._flush(name)

    def _flush(self, name: str) -> None:
        """Write a variable's queued values and fold them into its CRC-32 for the read-back."""
        start, pending, _ = self._queued.pop(name, (0, [], 0))
        if not pending:
            return
        values = pending[0] if len(pending) == 1 else np.concatenate(pending)
        try:
            self._nc[name][start : start + len(values)] = values
        except (RuntimeError, OSError) as err:  # a chunk the cache flushed failed
            raise self._unstorable(err) from None
        if not self._scratch:
            self._crc[name] = zlib.crc32(np.ascontiguousarray(values), self._crc.get(name, 0))

    def _unstorable(self, err: Exception) -> CaptureError:
        """Why HDF5 could not store a chunk. netCDF-C says only "HDF error", whether the disk is
        full or blosc could not shrink the chunk, so the file system is asked first (the
        temporary is about to be removed): a full disk, a quota or a read-only folder is a
        :class:`CaptureWriteError`, which no other compression would cure; only then is it
        blosc's :class:`UnshrinkableChunk`, which the twin writes again with zlib."""
        cause = _no_room(self.tmp, self._room())
        if cause is None and isinstance(err, OSError) and err.errno is not None:
            cause = err
        if cause is not None:
            return _cannot_write(self.path, cause, self.tmp)
        compression = self._compression[0]
        if compression is not None and compression.startswith("blosc"):
            return UnshrinkableChunk(
                f"{self.path}: HDF5 could not store a chunk ({err}) with compression "
                f"{compression}, whose blosc filter fails on data it cannot shrink; "
                f"zlib stores any data"
            )
        return CaptureError(
            f"{self.path}: HDF5 could not store a chunk ({err}) with compression {compression}"
        )

    def _flush_all(self) -> None:
        """The queued values, written before the file closes; a failure leaves no file."""
        try:
            for name in list(self._queued):
                self._flush(name)
        except CaptureError:
            nc, self._nc = self._nc, None
            with suppress(RuntimeError, OSError):
                nc.close()
            _remove(self.tmp)
            raise

    def write_truth_attrs(self, attrs: Mapping[str, object]) -> None:
        """The twin's true parameters, as attributes of /truth (states go through ``write``)."""
        assert self._nc is not None and self.truth, "declare truth states to write /truth"
        self._nc["truth"].setncatts({k: _attr(v) for k, v in attrs.items()})

    def __exit__(self, exc_type, exc, tb) -> None:
        began = time.perf_counter()
        if exc_type is None and self._nc is not None:
            self._flush_all()
        nc, self._nc = self._nc, None
        try:
            if nc is not None:
                if exc_type is None:
                    nc.clipped_samples = int(sum(self.clipped.values()))
                nc.close()  # flushes the chunks still cached
                self._seconds["packing and writing"] += time.perf_counter() - began
        except (RuntimeError, OSError) as err:
            problem = self._unstorable(err) if exc_type is None else None
            _remove(self.tmp)
            if problem is not None:
                raise problem from None
        if exc_type is not None:
            _remove(self.tmp)
            return
        expected = {
            "time": self.n_samples,
            "time_slow": self.n_slow,
            "time_truth": -(-self.n_samples // self.truth_decimation) if self.truth else 0,
        }
        short = {d: p for d, p in self._pos.items() if p != expected[d]}
        if short:
            _remove(self.tmp)
            raise ValueError(f"{self.path}: writer stopped early at {short} samples")
        began = time.perf_counter()
        problem = None if self._scratch else _read_back(self.tmp, self._crc, self._chunk_len)
        self._seconds["reading back"] = time.perf_counter() - began
        LOG.info(
            "%s: %s", self.path, ", ".join(f"{what} {s:.2f} s" for what, s in self._seconds.items())
        )
        if problem:
            _remove(self.tmp)
            raise _fail(self.path, f"not renamed into place: {problem}")
        try:
            os.replace(self.tmp, self.path)
        except OSError as err:  # the folder turned read-only while the capture was written
            _remove(self.tmp)
            raise _cannot_write(self.path, err, self.tmp) from None

    def scan_report(self) -> ScanReport:
        """What :func:`scan_capture` reports for the capture written, without reading it again: the
        counts are taken from the codes as they were written, which the read-back showed to be the
        codes on disk; the structure is checked as :func:`open_capture` checks it."""
        open_capture(self.path).close()
        fs = self._rate["time"]
        scanned = [c for c, spec in self.channels.items() if spec.dim == "time" or self.n_slow]
        return ScanReport(
            str(self.path),
            self.n_samples,
            fs,
            self.n_samples / fs,
            tuple(self.channels),
            {c: self.stats.nan.get(c, 0) for c in scanned},
            {c: self.stats.clipped.get(c, 0) for c in scanned},
        )


def _read_back(path: Path, crcs: Mapping[str, int], chunk_len: int) -> str | None:
    """Read every written variable back and compare it with the CRC-32 taken while writing; what
    differs, or None."""
    try:
        with netCDF4.Dataset(path, "r") as nc:
            # netCDF-C's default cache, 64 MB per variable, grew the writer with the capture
            # (0.9 GB at 77 M samples)
            _limit_chunk_cache(nc)
            for name, written in crcs.items():
                var = nc[name]
                var.set_auto_maskandscale(False)
                crc = 0
                step = 16 * chunk_len
                for start in range(0, var.shape[0], step):
                    crc = zlib.crc32(np.ascontiguousarray(var[start : start + step]), crc)
                if crc != written:
                    return f"variable {name} read back differs from what was written"
    except Exception as err:  # HDF5 checksum or structure errors surface as RuntimeError/OSError
        return f"read-back failed ({type(err).__name__}: {err})"
    return None


def _cannot_write(
    path: Path, err: OSError, tmp: Path | None = None, what: str = "capture"
) -> CaptureWriteError:
    """``<file>: cannot write the <what>: <the cause>``, from the OS's errno."""
    if err.errno == errno.ENAMETOOLONG:
        reason = _name_too_long(path, tmp)
    else:
        reason = WRITE_ERRNO.get(err.errno, err.strerror or str(err))
    return CaptureWriteError(f"{path}: cannot write the {what}: {reason}")


def _name_too_long(path: Path, tmp: Path | None) -> str:
    folder = path.parent
    while not folder.exists() and folder != folder.parent:
        folder = folder.parent
    try:
        name_max = os.pathconf(folder, "PC_NAME_MAX")
        path_max = os.pathconf(folder, "PC_PATH_MAX")
    except (OSError, ValueError):
        name_max, path_max = 255, 4096
    for what, name in (("its name", path.name), ("its temporary's name", tmp and tmp.name)):
        if name and len(os.fsencode(name)) > name_max:
            return (
                f"file name too long ({what} has {len(os.fsencode(name))} bytes, "
                f"the file system allows {name_max})"
            )
    size = len(os.fsencode(str((tmp or path).absolute())))
    return f"file name too long (the path has {size} bytes, the file system allows {path_max})"


def _no_room(tmp: Path | None, size: int) -> OSError | None:
    """The OSError the temporary's file system raises when asked for ``size`` more bytes in it
    (ENOSPC, EDQUOT, EFBIG, EROFS, …), or None when it has them. Only called when a write has
    failed: the temporary is removed next."""
    if tmp is None:
        return None
    try:
        fd = os.open(tmp, os.O_WRONLY | os.O_CREAT)
    except OSError as err:
        return err
    try:
        if hasattr(os, "posix_fallocate"):
            os.posix_fallocate(fd, os.fstat(fd).st_size, size)
        elif shutil.disk_usage(tmp.parent).free < size:
            return OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
    except OSError as err:
        if err.errno in (errno.EINVAL, errno.EOPNOTSUPP, errno.ENODEV):
            return None  # the file system cannot say; not a full disk as far as anyone knows
        return err
    finally:
        os.close(fd)
    return None


def _remove(path: Path | None) -> None:
    """Remove a temporary if the folder lets us (a read-only one does not: its error says so)."""
    if path is not None:
        try:
            path.unlink(missing_ok=True)
        except OSError:
            pass


def compression_settings(capture: Mapping[str, object]) -> dict[str, object]:
    """A :class:`CaptureWriter`'s compression arguments from the config's ``capture`` block
    (``compression``: one of COMPRESSIONS or ``none``; ``complevel``)."""
    name = capture["compression"]
    return {"compression": None if name == "none" else name, "complevel": int(capture["complevel"])}


def _filters(compression: str | None, complevel: int, chunk_bytes: int) -> dict[str, object]:
    """createVariable's filters for chunks of ``chunk_bytes``: a compression of the contract's, with
    HDF5's shuffle before zlib and zstd (blosc shuffles bytes itself), and a Fletcher-32 checksum on
    every chunk. HDF5's blosc filter fails on a chunk it cannot shrink, which every chunk of a few
    samples is (blosc adds a 16-byte header): those variables (the 10 Hz thermometers of a short
    run) are stored with zlib level 1 instead."""
    if compression is not None and compression not in COMPRESSIONS:
        raise ValueError(
            f"capture compression {compression!r} is none of {', '.join(COMPRESSIONS)} (or none)"
        )
    if compression is not None and compression.startswith("blosc"):
        if chunk_bytes >= BLOSC_MIN_CHUNK_BYTES:
            return {
                "compression": compression,
                "complevel": complevel,
                "shuffle": False,
                "fletcher32": True,
            }
        compression, complevel = "zlib", 1
    return {
        "compression": compression,
        "complevel": complevel,
        "shuffle": compression is not None,
        "fletcher32": True,
    }


def _limit_chunk_cache(group: netCDF4.Dataset | netCDF4.Group) -> None:
    """Cap every variable's chunk cache, in the file and its groups, at CHUNK_CACHE_BYTES."""
    for var in group.variables.values():
        var.set_var_chunk_cache(size=CHUNK_CACHE_BYTES)
    for sub in group.groups.values():
        _limit_chunk_cache(sub)


def _attr(value: object) -> object:
    """netCDF attributes cannot hold None or bool; store them as text."""
    if value is None or isinstance(value, bool):
        return str(value)
    return value


@dataclass
class ChunkStats:
    """Quality counts accumulated while a capture is streamed (reported in provenance)."""

    nan: dict[str, int] = field(default_factory=dict)
    clipped: dict[str, int] = field(default_factory=dict)

    def add(
        self,
        name: str,
        codes: np.ndarray,
        missing: np.ndarray | None = None,
        missing_at_full_scale: int = 0,
        clipped: int | None = None,
    ) -> int:
        """Count a chunk's missing and full-scale codes; returns the missing count. ``missing``:
        the chunk's missing samples when the caller has them (else ``codes == FILL``);
        ``missing_at_full_scale``: how many of them are ±INT16_FULL codes (a channel whose
        missing code is −32767, netCDF's default fill), which are missing, not clipped;
        ``clipped``: the clipped count when the caller has it."""
        n_missing = int(np.count_nonzero(codes == FILL if missing is None else missing))
        self.nan[name] = self.nan.get(name, 0) + n_missing
        if clipped is None:
            clipped = int(np.count_nonzero(np.abs(codes) == INT16_FULL)) - missing_at_full_scale
        self.clipped[name] = self.clipped.get(name, 0) + clipped
        return n_missing


class Capture:
    """A validated capture, open for streaming reads. Use as a context manager."""

    def __init__(self, path: os.PathLike | str, nc: netCDF4.Dataset, require: Sequence[str] = ()):
        self.path = Path(path)
        self._nc = nc
        self.attrs: dict[str, object] = {k: nc.getncattr(k) for k in nc.ncattrs()}
        self.fs = float(self.attrs["fs"])
        self.n = len(nc.dimensions["time"])
        self.n_slow = len(nc.dimensions["time_slow"]) if "time_slow" in nc.dimensions else 0
        self.channels = [v for v in nc.variables if v in CHANNEL_UNITS]
        self.stats = ChunkStats()
        self.required = frozenset(require)  # channels whose being entirely NaN stops the analysis
        self._finite_seen: set[str] = set()
        # per channel: its missing codes besides FILL (module docstring), checked on open
        self._missing_codes = {c: missing_codes(self.path, nc[c]) for c in self.channels}
        self._varied: set[str] = set()  # channels seen to take two different finite codes
        self._first_code: dict[str, int] = {}

    # -- context management -------------------------------------------------------------
    def close(self) -> None:
        self._nc.close()

    def __enter__(self) -> Capture:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def length(self, dim: str = "time") -> int:
        return self.n if dim == "time" else self.n_slow

    @property
    def duration(self) -> float:
        return self.n / self.fs

    @property
    def slow_rate(self) -> float:
        """The thermometers' sampling rate [Hz] (their time axis's, checked on open)."""
        return float(self._nc["time_slow"].sampling_rate)

    def resolution(self, name: str) -> float:
        """One ADC step of a channel, in its units."""
        self._require([name])
        return float(self._nc[name].scale_factor)

    def attribute(self, name: str) -> object:
        """A global attribute an analysis computes with: absent, it stops with one line (never a
        default that would change the result)."""
        if name not in self.attrs:
            raise _fail(self.path, f"missing global attribute {name!r} (docs/capture-contract.md)")
        return self.attrs[name]

    @property
    def has_truth(self) -> bool:
        return "truth" in self._nc.groups

    def require_samples(self, minimum: int, purpose: str) -> None:
        """Stop in one line when the capture holds fewer than ``minimum`` samples, the least
        ``purpose`` (say "ripple extraction: one window of np·ns = 4·12 samples") can work with
        (the module docstring's "Minimum length")."""
        if self.n < minimum:
            raise _too_short(self.path, self.n, minimum, purpose)

    def require_varying(self, names: Sequence[str], purpose: str) -> None:
        """After a whole pass over ``names``: stop in one line at the first channel that held one
        value only (a constant drive has no stroke, no gain, no loop to measure)."""
        for name in names:
            if name not in self._varied and name in self._first_code:
                code = self._first_code[name]
                value = code * float(self._nc[name].scale_factor) + float(
                    getattr(self._nc[name], "add_offset", 0.0)
                )
                raise _fail(
                    self.path,
                    f"channel {name} is constant ({value:g} {CHANNEL_UNITS[name][0]} in every "
                    f"sample that is not missing): {purpose} needs it to vary",
                )

    def _note_variation(self, name: str, finite: np.ndarray) -> None:
        lo, hi = int(finite.min()), int(finite.max())
        first = self._first_code.setdefault(name, lo)
        if lo != hi or lo != first:
            self._varied.add(name)

    def _decode(self, name: str, codes: np.ndarray) -> np.ndarray:
        var = self._nc[name]
        extra = self._missing_codes[name]  # none in a CaptureWriter's capture: _FillValue is FILL
        if extra == (NC_DEFAULT_FILL_I2,):  # no _FillValue: −32768 and −32767, adjacent codes
            missing = codes <= NC_DEFAULT_FILL_I2
            clipped = int(np.count_nonzero(codes == INT16_FULL))  # −32767 is missing
            n_missing = self.stats.add(name, codes, missing, clipped=clipped)
        else:
            missing = codes == FILL
            at_full_scale = 0
            for code in extra:
                hit = codes == code
                missing |= hit
                if abs(code) == INT16_FULL:
                    at_full_scale += int(np.count_nonzero(hit))
            n_missing = self.stats.add(name, codes, missing, at_full_scale)
        if n_missing < codes.size:
            self._finite_seen.add(name)
            if name not in self._varied:  # settled by the first chunk of any channel that varies
                self._note_variation(name, codes[~missing] if n_missing else codes)
        values = codes * float(var.scale_factor)  # float64, as codes.astype(float64) * scale
        values += float(var.add_offset)
        if n_missing:
            values[missing] = np.nan
        return values

    def _check_not_all_missing(self, names: Sequence[str], dim: str) -> None:
        """After a whole pass: a channel the analysis requires that held no sample at all stops
        it here, with one line, instead of deep inside (empty reductions, division by zero)."""
        empty = [n for n in names if n in self.required and n not in self._finite_seen]
        if empty:
            raise _fail(
                self.path,
                f"channel {empty[0]} is entirely NaN (all {self.length(dim)} samples missing): "
                f"this analysis needs it",
            )

    def read(
        self, names: Sequence[str], start: int = 0, stop: int | None = None, dim: str = "time"
    ) -> dict[str, np.ndarray]:
        """Channels ``names`` over samples [start, stop) as float64 in SI units (NaN where
        missing)."""
        self._require(names)
        out = {}
        for name in names:
            var = self._nc[name]
            var.set_auto_maskandscale(False)
            try:
                codes = np.asarray(var[start:stop])
            except (RuntimeError, OSError) as err:  # HDF5 checksum or a damaged chunk
                raise _fail(
                    self.path,
                    f"unreadable capture (channel {name}, samples {start}–"
                    f"{stop if stop is not None else self.length(dim)}: {err})",
                ) from None
            out[name] = self._decode(name, codes)
        if start == 0 and (stop is None or stop >= self.length(dim)):
            self._check_not_all_missing(names, dim)
        return out

    def iter_chunks(
        self, names: Sequence[str], chunk_len: int = 1 << 18, dim: str = "time"
    ) -> Iterator[tuple[int, dict[str, np.ndarray]]]:
        """Stream ``names`` in chunks: yields (first sample index, {name: float64 array}).

        The time axis is checked chunk by chunk, so a gap anywhere in the file is caught
        without ever holding more than one chunk in memory.
        """
        n = self.length(dim)
        rate = self.fs if dim == "time" else float(self._nc["time_slow"].sampling_rate)
        tvar = self._nc[dim]
        tvar.set_auto_mask(
            False
        )  # no masked array per chunk: a missing time fails the check as its fill value
        progress = _Progress(f"{self.path} read", n)
        for start in range(0, n, chunk_len):
            stop = min(n, start + chunk_len)
            t = np.asarray(tvar[start:stop], dtype=np.float64)
            off = np.abs(t - np.arange(start, stop) / rate)
            if not off.max() <= 0.25 / rate:  # NaN fails too
                k = start + int(np.argmax(~(off <= 0.25 / rate)))
                raise _fail(
                    self.path,
                    f"time axis breaks at sample {k} (t = {t[k - start]:.6g} s, "
                    f"expected {k / rate:.6g} s at fs = {rate:g} Hz)",
                )
            yield start, self.read(names, start, stop, dim)
            progress(stop)
        self._check_not_all_missing(names, dim)

    def read_truth(self) -> tuple[dict[str, object], dict[str, np.ndarray]]:
        """The twin's ground truth (parameters, states); only tests and the scorecard call this."""
        if not self.has_truth:
            raise _fail(self.path, "has no /truth group (not a simulated capture)")
        g = self._nc.groups["truth"]
        return (
            {k: g.getncattr(k) for k in g.ncattrs()},
            {k: np.asarray(v[:]) for k, v in g.variables.items()},
        )

    def _require(self, names: Sequence[str]) -> None:
        missing = [n for n in names if n not in self._nc.variables]
        if missing:
            raise _fail(self.path, f"missing channel(s) {', '.join(missing)}")


def open_capture(
    path: os.PathLike | str,
    require: Sequence[str] = (),
    min_samples: int = MIN_SAMPLES,
    purpose: str = "this analysis",
) -> Capture:
    """Open and validate a capture's structure (Design: "Validation on open").

    Checks that it is a readable netCDF4 file with a non-empty ``time`` dimension, that the
    required channels exist with their contract units and int16 packing, that the time axis
    starts at 0 and ends at (n−1)/fs, and that fs agrees with the folding equation when the
    ripple sampling attributes are present; that every channel is one series along its time
    axis, its packing within bounds (:data:`MIN_SCALE`, :data:`MAX_FULL_SCALE`) and its missing
    codes numbers; that it holds at least :data:`MIN_SAMPLES`, and ``min_samples`` for the
    ``purpose`` of the analysis that opens it (the module docstring's "Minimum length").
    Sample-level counts (missing, clipping, gaps in the middle of the time axis) are gathered
    while streaming; see :func:`scan_capture`.
    """
    path = Path(path)
    if not path.exists():
        raise _fail(path, "no such capture")
    try:
        nc = netCDF4.Dataset(path, "r")
    except OSError as err:
        raise _fail(path, f"not a readable netCDF4 capture ({err.strerror or err})") from None
    try:
        _limit_chunk_cache(nc)
        _check_structure(path, nc, require, min_samples, purpose)
    except CaptureError:
        nc.close()
        raise
    except Exception as err:  # a truncated file can fail on any access, not only on open
        nc.close()
        raise _fail(path, f"unreadable capture ({type(err).__name__}: {err})") from None
    return Capture(path, nc, require)


@dataclass(frozen=True)
class Header:
    """What a capture declares, read without judging it: its global attributes, and per channel
    its units, sample count and the full scale its packing spans. A comparison with the
    dataset's manifest names both files, so it runs before :func:`open_capture` refuses a
    capture for its own contract alone."""

    attrs: dict[str, object]
    units: dict[str, str | None]
    samples: dict[str, int]
    ranges: dict[str, tuple[float, float]]


def read_header(path: os.PathLike | str) -> Header:
    """The capture's :class:`Header`; CaptureError if the file is not a readable netCDF4 file."""
    path = Path(path)
    if not path.exists():
        raise _fail(path, "no such capture")
    try:
        with netCDF4.Dataset(path, "r") as nc:
            channels = [nc[v] for v in nc.variables if v in CHANNEL_UNITS]
            return Header(
                {k: nc.getncattr(k) for k in nc.ncattrs()},
                {v.name: getattr(v, "units", None) for v in channels},
                {v.name: int(v.shape[0]) if v.ndim else 1 for v in channels},
                {v.name: _full_scale(v) for v in channels},
            )
    except OSError as err:
        raise _fail(path, f"not a readable netCDF4 capture ({err.strerror or err})") from None
    except (RuntimeError, ValueError, KeyError, IndexError) as err:  # a damaged header
        raise _fail(path, f"unreadable capture ({type(err).__name__}: {err})") from None


def _full_scale(var: netCDF4.Variable) -> tuple[float, float]:
    """The range the packing spans (NaN where scale_factor or add_offset is not one number)."""
    scale = _number(getattr(var, "scale_factor", 1.0))
    offset = _number(getattr(var, "add_offset", 0.0))
    if scale is None or offset is None:
        return math.nan, math.nan
    return offset - scale * INT16_FULL, offset + scale * INT16_FULL


def compression_of(var: netCDF4.Variable) -> str | None:
    """The compression a variable's chunks are stored with (None: uncompressed)."""
    filters = var.filters() or {}
    if filters.get("blosc"):
        return filters["blosc"]["compressor"]
    return next((name for name in ("zlib", "zstd", "bzip2", "szip") if filters.get(name)), None)


def _number(value: object) -> float | None:
    """An attribute's value as one float, or None when it is text, a vector or not a number."""
    if isinstance(value, (str, bytes)):
        return None
    array = np.asarray(value)
    if array.size != 1 or array.dtype.kind not in "iuf":
        return None
    return float(array.reshape(()))


def sampling_rate(path: os.PathLike | str, value: object) -> float:
    """The global attribute ``fs`` as a finite, positive number of Hz; one line naming the file
    otherwise (text such as '48000' or '48 kHz', several values, NaN, ≤ 0)."""
    if isinstance(value, (str, bytes)):
        return _bad_fs(path, f"fs is stored as text ({value!r})")
    fs = _number(value)
    if fs is None:
        return _bad_fs(path, f"fs = {np.asarray(value).tolist()!r} is not one number")
    if not (math.isfinite(fs) and fs > 0):
        raise _fail(path, f"fs = {fs} must be positive and finite")
    return fs


def _bad_fs(path: os.PathLike | str, problem: str) -> float:
    raise _fail(path, f"{problem}: it must be one number, the sampling rate in Hz")


def missing_codes(path: os.PathLike | str, var: netCDF4.Variable) -> tuple[int, ...]:
    """The int16 codes of a channel that stand for a missing sample besides FILL, sorted: its
    ``_FillValue`` (netCDF's default −32767 when it declares none: netCDF4-python masks that
    too) and its ``missing_value`` codes (CF: a scalar or a vector, in the packed domain). A
    numeric value no int16 sample can equal (−9999.5, 1e6, NaN) marks none, as in netCDF4-python;
    text is refused in one line."""
    attrs = var.ncattrs()
    values = [var.getncattr("_FillValue") if "_FillValue" in attrs else NC_DEFAULT_FILL_I2]
    if "missing_value" in attrs:
        declared = var.getncattr("missing_value")
        if isinstance(declared, (str, bytes)) or np.asarray(declared).dtype.kind not in "iuf":
            raise _fail(
                path,
                f"channel {var.name} has missing_value {declared!r}: it must be a number or "
                f"numbers, the packed int16 codes of missing samples (CF)",
            )
        values += list(np.atleast_1d(declared).ravel())
    codes = set()
    for value in values:
        code = float(value)
        if code.is_integer() and -32768 <= code <= 32767:
            codes.add(int(code))
    codes.discard(int(FILL))
    return tuple(sorted(codes))


def _too_short(path: os.PathLike | str, n: int, minimum: int, purpose: str) -> CaptureError:
    return _fail(
        path,
        f"capture too short: {n} sample{'' if n == 1 else 's'}, {purpose} needs at least {minimum}",
    )


def _check_channel(path: Path, nc: netCDF4.Dataset, name: str, n: int) -> None:
    """One channel: units, packing (int16, a scale and offset within bounds, missing codes that
    are numbers), compression, and one sample per instant of its time axis."""
    var = nc[name]
    units = getattr(var, "units", None)
    if units != CHANNEL_UNITS[name][0]:
        raise _fail(
            path,
            f"channel {name} has units {units!r}, the contract says {CHANNEL_UNITS[name][0]!r}",
        )
    if var.dtype != np.int16 or "scale_factor" not in var.ncattrs():
        raise _fail(path, f"channel {name} is not packed int16 with scale_factor/add_offset")
    axis = "time_slow" if name in SLOW_CHANNELS else "time"
    if var.ndim != 1:
        shape = " × ".join(f"{d} {k}" for d, k in zip(var.dimensions, var.shape, strict=True))
        raise _fail(
            path,
            f"channel {name} is {var.ndim}-D ({shape or 'a scalar'}): a channel is one series "
            f"of samples along {axis}",
        )
    if var.dimensions[0] != axis:
        raise _fail(
            path,
            f"channel {name} has {var.shape[0]} samples along {var.dimensions[0]!r}, "
            f"not along {axis!r}"
            + (f" ({n} samples)" if axis == "time" else "")
            + f": each channel holds one sample per instant of {axis}",
        )
    compression = compression_of(var)
    if compression not in (*COMPRESSIONS, None):
        raise _fail(
            path,
            f"channel {name} is compressed with {compression}: the contract allows "
            f"{', '.join(COMPRESSIONS)} or none",
        )
    raw_scale, raw_offset = var.getncattr("scale_factor"), getattr(var, "add_offset", 0.0)
    scale, offset = _number(raw_scale), _number(raw_offset)
    if scale is None or offset is None:
        raise _fail(
            path,
            f"channel {name} has scale_factor {raw_scale!r} and add_offset {raw_offset!r}: "
            f"the packing needs one number each",
        )
    if not (math.isfinite(scale) and scale > 0 and math.isfinite(offset)):
        raise _fail(
            path,
            f"channel {name} has scale_factor {scale:g} and add_offset {offset:g}: "
            f"the packing needs a finite, positive scale and a finite offset",
        )
    full = abs(offset) + scale * INT16_FULL  # Python floats: inf on overflow
    if scale < MIN_SCALE or not full <= MAX_FULL_SCALE:
        unit = CHANNEL_UNITS[name][0]
        span = f"a step of {scale:g} {unit}" if scale < MIN_SCALE else f"a full scale of {full:g}"
        raise _fail(
            path,
            f"channel {name} has scale_factor {scale:g} and add_offset {offset:g}, {span}: "
            f"the analyses compute with steps ≥ {MIN_SCALE:g} and full scales "
            f"(|add_offset| + 32767·scale_factor) ≤ {MAX_FULL_SCALE:g} {unit}",
        )
    missing_codes(path, var)


def _check_structure(
    path: Path, nc: netCDF4.Dataset, require: Sequence[str], min_samples: int, purpose: str
) -> None:
    if "time" not in nc.dimensions:
        raise _fail(path, "no 'time' dimension")
    n = len(nc.dimensions["time"])
    if n == 0:
        raise _fail(path, "empty capture (time has 0 samples)")
    if "fs" not in nc.ncattrs():
        raise _fail(path, "missing global attribute 'fs'")
    fs = sampling_rate(path, nc.getncattr("fs"))
    if n < MIN_SAMPLES:
        raise _too_short(path, n, MIN_SAMPLES, "any capture (a time axis with a step)")
    if n < min_samples:
        raise _too_short(path, n, min_samples, purpose)
    missing = [c for c in require if c not in nc.variables]
    if missing:
        raise _fail(path, f"missing channel(s) {', '.join(missing)} needed by this analysis")
    if "time" not in nc.variables or nc["time"].dimensions != ("time",):
        raise _fail(path, "no time axis: a variable 'time' [s] along the dimension 'time'")
    channels = [c for c in nc.variables if c in CHANNEL_UNITS]
    for name in channels:
        _check_channel(path, nc, name, n)
    if any(c in SLOW_CHANNELS for c in channels):
        slow = nc.variables.get("time_slow")
        rate = _number(getattr(slow, "sampling_rate", None))
        if slow is None or slow.dimensions != ("time_slow",) or not (rate and rate > 0):
            raise _fail(
                path,
                "the thermometers' time axis 'time_slow' is missing or has no positive "
                "sampling_rate [Hz]",
            )
    t = nc["time"]
    t0, t1 = float(t[0]), float(t[n - 1])
    if abs(t0) > 0.25 / fs or abs(t1 - (n - 1) / fs) > 0.25 / fs + FS_RTOL * t1:
        raise _fail(
            path,
            f"time axis runs {t0:.6g}..{t1:.6g} s, not 0..{(n - 1) / fs:.6g} s "
            f"for {n} samples at fs = {fs:g} Hz (gap or wrong fs)",
        )
    attrs = set(nc.ncattrs())
    if {"fr_nominal", "ns", "nf"} <= attrs:
        plan = {k: _number(nc.getncattr(k)) for k in ("fr_nominal", "ns", "nf")}
        bad = next((k for k, v in plan.items() if v is None or not math.isfinite(v)), None)
        if bad is not None:
            raise _fail(path, f"global attribute {bad} = {nc.getncattr(bad)!r} is not a number")
        fr, ns, nf = plan["fr_nominal"], int(plan["ns"]), int(plan["nf"])
        try:
            expected = folded_fs(fr, ns, nf)
        except ZeroDivisionError:
            expected = math.nan
        if not math.isclose(fs, expected, rel_tol=FS_RTOL):
            raise _fail(
                path,
                f"fs = {fs:g} Hz violates the folding equation (Eq 3.4/3.5): "
                f"fr = {fr:g} Hz, ns = {ns}, nf = {nf} need fs = {expected:g} Hz",
            )


@dataclass(frozen=True)
class ScanReport:
    """Sample-level quality of a whole capture, as recorded in provenance and the report."""

    path: str
    n_samples: int
    fs: float
    duration_s: float
    channels: tuple[str, ...]
    nan: dict[str, int]
    clipped: dict[str, int]


def write_scan_report(
    scan: ScanReport,
    path: os.PathLike | str,
    inputs: Sequence[os.PathLike | str] = (),
    config: Mapping[str, object] | None = None,
) -> None:
    """A capture's QC report (qc/<experiment>.json): the scan and the provenance of the capture
    (and of whatever else it was checked against, say the manifest, or ``config``: the parts of
    it the checks read)."""
    prov = provenance(list(inputs) or [scan.path], config=config)
    write_json(asdict(scan) | {"provenance": prov}, path)


def scan_capture(
    path: os.PathLike | str, require: Sequence[str] = (), chunk_len: int = 1 << 18
) -> ScanReport:
    """Stream a whole capture once: validates the time axis and counts NaN and clipped samples."""
    with open_capture(path, require) as cap:
        fast = [c for c in cap.channels if c not in SLOW_CHANNELS]
        slow = [c for c in cap.channels if c in SLOW_CHANNELS]
        for _ in cap.iter_chunks(fast, chunk_len):
            pass
        if slow and cap.n_slow:
            for _ in cap.iter_chunks(slow, chunk_len, dim="time_slow"):
                pass
        return ScanReport(
            str(path),
            cap.n,
            cap.fs,
            cap.duration,
            tuple(cap.channels),
            dict(cap.stats.nan),
            dict(cap.stats.clipped),
        )


class SeriesWriter:
    """Derived series (e.g. ripple-block estimates) appended chunk by chunk to a netCDF file.

    Analyses write their intermediate results with it so their memory stays flat; like
    :class:`CaptureWriter`, the file appears only when complete. Like a table, it gets a
    provenance sidecar ``<series>.json`` with the sha256 of the ``inputs`` it was made from (the
    capture, a model): ``selfsense audit`` follows a table made from the series down to the
    capture, so a capture changed or deleted under it is found (the inputs are required: an
    intermediate without them would end the audit's chain there). A full disk is one line
    naming the series, as for a capture, and leaves neither file.
    """

    def __init__(
        self,
        path: os.PathLike | str,
        variables: Mapping[str, str],
        attrs: Mapping[str, object] | None = None,
        dim: str = "block",
        *,
        inputs: Sequence[os.PathLike | str],
        config: Mapping[str, object] | None = None,
    ):
        self.path = Path(path)
        self.tmp: Path | None = None
        self.variables = dict(variables)  # name -> units
        self.attrs = dict(attrs or {})
        self.dim = dim
        self.inputs = [os.fspath(p) for p in inputs]
        self.config = dict(config or {})
        self.n = 0
        self._nc: netCDF4.Dataset | None = None

    def __enter__(self) -> SeriesWriter:
        try:
            self.tmp = temporary_path(self.path)
            nc = netCDF4.Dataset(self.tmp, "w", format="NETCDF4")
        except OSError as err:
            raise self._unstorable(err) from None
        try:
            nc.setncatts({k: _attr(v) for k, v in self.attrs.items()})
            nc.createDimension(self.dim, None)
            for name, units in self.variables.items():
                nc.createVariable(
                    name,
                    "f8",
                    (self.dim,),
                    zlib=True,
                    complevel=1,
                    shuffle=True,
                    chunksizes=(1 << 14,),
                ).units = units
            _limit_chunk_cache(nc)
        except BaseException:
            nc.close()
            _remove(self.tmp)
            raise
        self._nc = nc
        return self

    def write(self, data: Mapping[str, np.ndarray]) -> None:
        assert self._nc is not None, "use SeriesWriter inside a with block"
        n = len(next(iter(data.values())))
        try:
            for name in self.variables:
                self._nc[name][self.n : self.n + n] = data[name]
        except (RuntimeError, OSError) as err:  # a chunk the cache flushed failed
            raise self._unstorable(err) from None
        self.n += n

    def _unstorable(self, err: Exception) -> CaptureError:
        """Why the series could not be written, in one line naming it: the file system is asked,
        as :meth:`CaptureWriter._unstorable` does (netCDF-C says only "HDF error")."""
        cause = _no_room(self.tmp, 1 << 20)  # a chunk of 16 384 f8 values, and metadata
        if cause is None and isinstance(err, OSError) and err.errno is not None:
            cause = err
        if cause is not None:
            return _cannot_write(self.path, cause, self.tmp, "series")
        return CaptureError(f"{self.path}: cannot write the series: HDF5 failed ({err})")

    def __exit__(self, exc_type, exc, tb) -> None:
        nc, self._nc = self._nc, None
        try:
            if nc is not None:
                nc.close()  # flushes the chunks still cached
        except (RuntimeError, OSError) as err:
            problem = self._unstorable(err) if exc_type is None else None
            _remove(self.tmp)
            if problem is not None:
                raise problem from None
        if exc_type is not None:
            _remove(self.tmp)
            return
        try:
            os.replace(self.tmp, self.path)
        except OSError as err:
            _remove(self.tmp)
            raise _cannot_write(self.path, err, self.tmp, "series") from None
        try:
            write_json(provenance(self.inputs, self.config), f"{self.path}.json")
        except BaseException:
            # a series without its sidecar would stop the audit's chain: neither is left
            self.path.unlink(missing_ok=True)
            raise


def series_scalars(path: os.PathLike | str) -> dict[str, float]:
    """The numeric attributes a :class:`SeriesWriter` stored with a series (say, a run's peaks)."""
    if not Path(path).exists():
        raise _fail(path, "no such series")
    try:
        with netCDF4.Dataset(path) as nc:
            return {
                k: float(v)
                for k in nc.ncattrs()
                if isinstance(v := nc.getncattr(k), (float, np.floating))
            }
    except OSError as err:
        raise _fail(path, f"not a readable netCDF4 series ({err.strerror or err})") from None


def read_series(
    path: os.PathLike | str, names: Sequence[str] | None = None
) -> dict[str, np.ndarray]:
    """A derived series written by :class:`SeriesWriter`, whole (they are ns× smaller than
    captures)."""
    if not Path(path).exists():  # netCDF-C would say only "No such file or directory"
        raise _fail(path, "no such series")
    try:
        with netCDF4.Dataset(path) as nc:
            names = list(nc.variables) if names is None else names
            missing = [n for n in names if n not in nc.variables]
            if missing:
                raise _fail(path, f"missing series {', '.join(missing)}")
            return {n: np.asarray(nc[n][:], dtype=np.float64) for n in names}
    except OSError as err:
        raise _fail(path, f"not a readable netCDF4 series ({err.strerror or err})") from None
