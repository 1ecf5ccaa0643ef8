"""Captures from other writers and hostile ones (docs/reliability.md): each channel's own
_FillValue / missing_value honoured as missing and never counted as clipped, shapes and packing
checked on open, a minimum length, and a capture that cannot be written (full disk, read-only
folder, a name too long) reported as such. Each fault ends in one line naming the file.
"""

import errno
import json
import math
import os

import netCDF4
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import selfsense.twin.experiment as twin
from selfsense.chapters.characterise import characterise_capture
from selfsense.io.capture import (
    CHARACTERISE_MIN_SAMPLES,
    FILL,
    INT16_FULL,
    NC_DEFAULT_FILL_I2,
    CaptureError,
    CaptureWriteError,
    CaptureWriter,
    UnshrinkableChunk,
    channel_spec,
    missing_codes,
    open_capture,
    scan_capture,
)
from selfsense.io.manifest import load_config

from ..helpers import FS, RANGES, ROOT, bench_manifest, leftovers, one_line, script

UNITS = {"U": "V", "I": "A", "Ur": "V", "Ir": "A", "x_laser": "m"}
LOOP_WIDTH = "x–U loop width [% of stroke]"


def signals(n):
    """A 10 Hz drive with a lagging x (a loop a few % of stroke wide) and a folded ripple."""
    t = np.arange(n) / FS
    w = 2 * np.pi * 10 * t
    return {
        "U": 50 - 50 * np.cos(w),
        "I": 0.05 * np.sin(w),
        "Ur": 0.1 * np.sin(2 * np.pi * 4000 * t),
        "Ir": 0.05 * np.cos(2 * np.pi * 4000 * t),
        "x_laser": 1e-6 + 1.5e-5 * (1 - np.cos(w - 0.1)),  # never code 0 (a fill below)
    }


def packing(channel):
    lo, hi = RANGES[channel]
    return (hi - lo) / (2 * INT16_FULL), (hi + lo) / 2


def foreign(path, n=9600, fill=None, missing_value=None, codes=None, attrs=None, edit=None):
    """A capture as another writer makes it, with netCDF4 directly: ``fill`` None declares no
    _FillValue (netCDF's default −32767 applies), ``codes`` {channel: {index: code}} overwrites
    packed samples; ``edit(nc)`` changes anything else before the file is closed."""
    values = signals(n)
    with netCDF4.Dataset(path, "w") as nc:
        nc.setncatts(
            {"fs": FS, "fr_nominal": 1e5, "ns": 12, "nf": 4, "warmup_s": 0.0} | (attrs or {})
        )
        nc.createDimension("time", n)
        t = nc.createVariable("time", "f8", ("time",))
        t.units, t.sampling_rate = "s", FS
        t[:] = np.arange(n) / FS
        for name, x in values.items():
            var = nc.createVariable(name, "i2", ("time",), fill_value=fill)
            var.set_auto_maskandscale(False)
            scale, offset = packing(name)
            var.setncatts({"units": UNITS[name], "scale_factor": scale, "add_offset": offset})
            if missing_value is not None:
                var.setncattr("missing_value", missing_value)  # as typed: text, NaN
            packed = np.clip(np.rint((x - offset) / scale), -INT16_FULL, INT16_FULL)
            packed = packed.astype(np.int16)
            for index, code in (codes or {}).get(name, {}).items():
                packed[index] = code
            var[:] = packed
        if edit is not None:
            edit(nc)
    return path


def check(tmp_path, capture):
    """Rule check_capture on ``capture``: its QC report (a dict), or the CaptureError raised, in
    which case no report exists."""
    report = tmp_path / "qc" / f"{capture.stem}.json"
    try:
        script("check_capture").main(str(capture), bench_manifest(tmp_path), str(report))
    except CaptureError as err:
        assert not report.exists() and leftovers(tmp_path / "qc") == []
        return err
    return json.loads(report.read_text())


def coded(path, marks):
    """Per channel, how many of its packed samples carry one of the codes ``marks``."""
    with netCDF4.Dataset(path) as nc:
        out = {}
        for name in UNITS:
            nc[name].set_auto_maskandscale(False)
            out[name] = int(np.isin(nc[name][:], list(marks)).sum())
        return out


def burst(n, fraction=0.005, seed=0):
    """Indices of ``fraction`` of n samples, scattered (as a dropping ADC leaves them)."""
    return np.sort(np.random.default_rng(seed).choice(n, int(fraction * n), replace=False))


# -- missing samples: each channel's own fill value ----------------------------------------------


def test_the_default_int16_fill_of_another_writer_is_missing_not_clipped(tmp_path):
    n, hit = 9600, burst(9600)
    clean = foreign(tmp_path / "clean.nc", n)
    dropped = foreign(
        tmp_path / "ch3_sine_10hz.nc", n, codes={"x_laser": dict.fromkeys(hit, NC_DEFAULT_FILL_I2)}
    )
    qc = check(tmp_path, dropped)
    assert qc["nan"]["x_laser"] == len(hit) == 48 and qc["clipped"]["x_laser"] == 0
    with open_capture(dropped) as cap:
        x = cap.read(["x_laser"])["x_laser"]
    assert np.flatnonzero(np.isnan(x)).tolist() == hit.tolist()
    # the loop width stays the clean capture's (as −32767·scale it was −0.1 mm: 20.5 %, not 3.5 %)
    width = characterise_capture(dropped, 0.1, 1.0)[0][LOOP_WIDTH]
    assert width == pytest.approx(characterise_capture(clean, 0.1, 1.0)[0][LOOP_WIDTH], abs=0.5)


@pytest.mark.parametrize("fill", [0, -9999, INT16_FULL, -INT16_FULL])
def test_a_declared_fill_value_is_missing_and_never_clipped(tmp_path, fill):
    n, hit = 9600, burst(9600)
    capture = foreign(
        tmp_path / "ch3_sine_10hz.nc", n, fill=fill, codes={"x_laser": dict.fromkeys(hit, fill)}
    )
    qc = check(tmp_path, capture)
    assert qc["nan"]["x_laser"] == len(hit) and qc["clipped"]["x_laser"] == 0
    assert qc["nan"] == coded(capture, {fill, FILL})  # U, I, Ur, Ir cross 0: missing with fill 0


def test_a_declared_fill_makes_minus_32767_an_ordinary_clipped_sample(tmp_path):
    codes = {"x_laser": {10: -INT16_FULL, 20: INT16_FULL, 30: 0}}
    capture = foreign(tmp_path / "ch3_sine_10hz.nc", fill=0, codes=codes)
    qc = check(tmp_path, capture)
    assert qc["nan"]["x_laser"] == 1 and qc["clipped"]["x_laser"] == 2


@pytest.mark.parametrize("missing_value", [-9999, [-9999, 12345], np.array([-9999.0, 12345.0])])
def test_missing_value_scalar_or_vector_is_missing(tmp_path, missing_value):
    codes = {"U": {5: -9999, 6: 12345, 7: FILL}, "I": {100: -9999}}
    capture = foreign(
        tmp_path / "ch3_sine_10hz.nc", fill=0, missing_value=missing_value, codes=codes
    )
    expected = 3 if np.size(missing_value) == 2 else 2
    qc = check(tmp_path, capture)
    marks = {0, FILL, *np.atleast_1d(missing_value).astype(int).tolist()}
    assert qc["nan"] == coded(capture, marks)
    assert qc["nan"]["U"] == expected + coded(capture, {0})["U"] and qc["nan"]["I"] >= 1
    with open_capture(capture) as cap:
        u = cap.read(["U"])["U"]
    assert np.isnan(u[5]) and np.isnan(u[7]) and np.isnan(u[6]) == (expected == 3)


def test_a_missing_value_that_is_text_is_one_line(tmp_path):
    capture = foreign(tmp_path / "ch3_sine_10hz.nc", missing_value="n/a")
    one_line(str(check(tmp_path, capture)), capture, "channel", "missing_value 'n/a'", "number")


def test_the_twins_captures_declare_only_fill_and_count_as_before(tmp_path):
    """CaptureWriter's _FillValue is FILL: no extra code to compare, the same NaN and clipped
    counts as the writer took while writing (so the QC tables of the twin do not change)."""
    values = np.zeros(4800)
    values[100:110] = np.nan
    values[200:203] = 500.0
    values[300] = -500.0
    path = tmp_path / "c.nc"
    with CaptureWriter(path, {"fs": FS}, [channel_spec("U", -200, 200)], 4800) as w:
        w.write({"U": values})
    with netCDF4.Dataset(path) as nc:
        assert nc["U"]._FillValue == FILL and missing_codes(path, nc["U"]) == ()
    scan = scan_capture(path)
    assert scan == w.scan_report()
    assert scan.nan == {"U": 10} and scan.clipped == {"U": 4}


# -- shapes and attributes, on open and at QC ----------------------------------------------------


def _half_length_x(nc):
    nc.renameVariable("x_laser", "x_full")  # no channel of the contract: ignored
    nc.createDimension("time_half", len(nc.dimensions["time"]) // 2)
    var = nc.createVariable("x_laser", "i2", ("time_half",))
    var.setncatts({"units": "m", "scale_factor": 3e-9, "add_offset": 0.0})


def _two_d_u(nc):
    nc.createDimension("probe", 2)
    nc.renameVariable("U", "U_old")
    var = nc.createVariable("U", "i2", ("time", "probe"))
    var.setncatts({"units": "V", "scale_factor": 0.006, "add_offset": 0.0})


def _set(attr, value, channel=None):
    def edit(nc):
        (nc[channel] if channel else nc).setncattr(attr, value)

    return edit


HOSTILE = {  # fault: (edit, what the one line says)
    "channel half the length of time": (
        _half_length_x,
        ["channel x_laser has 4800 samples along 'time_half'", "not along 'time' (9600 samples)"],
    ),
    "2-D channel": (_two_d_u, ["channel U is 2-D (time 9600 × probe 2)", "one series"]),
    "fs stored as text": (_set("fs", "48000"), ["fs is stored as text ('48000')", "one number"]),
    "fs as text with a unit": (_set("fs", "48 kHz"), ["fs is stored as text ('48 kHz')"]),
    "fs holds two values": (_set("fs", np.array([48e3, 48e3])), ["is not one number"]),
    "scale_factor 1e305": (
        _set("scale_factor", 1e305, "U"),
        ["channel U has scale_factor 1e+305", "full scale of inf", "≤ 1e+30 V"],
    ),
    "scale_factor 1e-300": (
        _set("scale_factor", 1e-300, "U"),
        ["channel U has scale_factor 1e-300", "a step of 1e-300 V", "steps ≥ 1e-30"],
    ),
    "scale_factor as text": (_set("scale_factor", "0.006", "U"), ["needs one number each"]),
}


@pytest.mark.parametrize("fault", HOSTILE, ids=list(HOSTILE))
def test_hostile_shapes_and_attributes_stop_qc_in_one_line(tmp_path, fault):
    edit, fragments = HOSTILE[fault]
    capture = foreign(tmp_path / "ch3_sine_10hz.nc", edit=edit)
    one_line(str(check(tmp_path, capture)), capture, *fragments)
    with pytest.raises(CaptureError) as e:  # an analysis opening it stops the same way
        open_capture(capture)
    one_line(str(e.value), capture)


# -- minimum length ------------------------------------------------------------------------------


def test_a_one_sample_capture_is_one_line(tmp_path):
    capture = foreign(tmp_path / "ch3_sine_10hz.nc", n=1)
    one_line(str(check(tmp_path, capture)), capture, "capture too short: 1 sample", "at least 2")


def test_two_samples_pass_qc_but_not_an_analysis_that_needs_more(tmp_path):
    capture = foreign(tmp_path / "ch3_sine_10hz.nc", n=2)
    assert check(tmp_path, capture)["n_samples"] == 2  # the generic minimum
    with pytest.raises(CaptureError) as e:
        open_capture(capture, min_samples=CHARACTERISE_MIN_SAMPLES, purpose="characterise")
    one_line(str(e.value), capture, "capture too short: 2 samples, characterise needs at least 32")
    with open_capture(capture) as cap, pytest.raises(CaptureError) as e:
        cap.require_samples(4 * 12, "ripple extraction (one window, np·ns = 4·12)")
    one_line(
        str(e.value), capture, "ripple extraction (one window, np·ns = 4·12) needs at least 48"
    )


def test_a_constant_drive_is_one_line_after_the_pass(tmp_path):
    capture = foreign(tmp_path / "c.nc", codes={"U": {i: 100 for i in range(9600)}})
    with open_capture(capture) as cap:
        for _ in cap.iter_chunks(["U", "x_laser"], chunk_len=1000):
            pass
        cap.require_varying(["x_laser"], "characterise")  # varies: no verdict
        with pytest.raises(CaptureError) as e:
            cap.require_varying(["U", "x_laser"], "characterise")
    one_line(str(e.value), capture, "channel U is constant (0.61", "characterise needs it to vary")


# -- writing: full disk, read-only folder, a name too long ---------------------------------------

NOISE = np.random.default_rng(1).uniform(-200, 200, 4096)  # blosc cannot shrink it: HDF5 fails


def write_noise(path, compression="blosc_zstd"):
    with CaptureWriter(
        path, {"fs": FS}, [channel_spec("U", -200, 200)], len(NOISE), compression=compression
    ) as w:
        w.write({"U": NOISE})


def _full_disk(monkeypatch):
    """The file system refuses every allocation with ENOSPC (a real full disk needs a mount)."""

    def full(fd, offset, size):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(os, "posix_fallocate", full)


def test_a_full_disk_is_named_and_not_mistaken_for_blosc(tmp_path, monkeypatch):
    _full_disk(monkeypatch)
    with pytest.raises(CaptureWriteError) as e:
        write_noise(tmp_path / "c.nc")
    assert not isinstance(e.value, UnshrinkableChunk)
    one_line(str(e.value), tmp_path / "c.nc", "cannot write the capture: no space left on device")
    assert list(tmp_path.iterdir()) == []


def test_the_twin_does_not_retry_a_full_disk_with_zlib(tmp_path, monkeypatch):
    tried = []

    def simulate(path, *args, compression, complevel, **kwargs):
        tried.append(compression)
        write_noise(path, compression)

    monkeypatch.setattr(twin, "simulate_capture", simulate)
    _full_disk(monkeypatch)
    config = load_config(ROOT / "tests" / "config" / "smoke.yaml")
    with pytest.raises(CaptureWriteError) as e:
        twin.simulate_experiment(
            ROOT / "raw", "pi_p885", "ch3_sine_10hz", config, tmp_path / "c.nc"
        )
    assert tried == ["blosc_zstd"]
    one_line(str(e.value), tmp_path / "c.nc", "no space left on device")
    assert list(tmp_path.iterdir()) == []


def test_a_read_only_folder_is_named(tmp_path, monkeypatch):
    folder = tmp_path / "raw"
    folder.mkdir()
    if os.geteuid() == 0:  # root writes into a 0555 folder: the OS's answer is simulated
        real_open = os.open

        def refusing(path, flags, *args, **kwargs):
            if str(path).startswith(str(folder)) and flags & os.O_CREAT:
                raise PermissionError(errno.EACCES, os.strerror(errno.EACCES), str(path))
            return real_open(path, flags, *args, **kwargs)

        monkeypatch.setattr(os, "open", refusing)
    else:
        folder.chmod(0o555)
    try:
        with pytest.raises(CaptureWriteError) as e:
            write_noise(folder / "c.nc", "zlib")
    finally:
        folder.chmod(0o755)
    one_line(str(e.value), folder / "c.nc", "cannot write the capture: folder is read-only")
    assert list(folder.iterdir()) == []


def test_a_folder_turned_read_only_before_the_rename_is_named(tmp_path, monkeypatch):
    def read_only(src, dst):
        raise OSError(errno.EROFS, os.strerror(errno.EROFS), str(dst))

    monkeypatch.setattr(os, "replace", read_only)
    with pytest.raises(CaptureWriteError) as e:
        write_noise(tmp_path / "c.nc", "zlib")
    one_line(str(e.value), tmp_path / "c.nc", "folder is read-only (read-only file system)")
    assert list(tmp_path.iterdir()) == []


def test_a_300_character_experiment_name_is_named_too_long(tmp_path):
    path = tmp_path / f"{'x' * 300}.nc"
    config = load_config(ROOT / "tests" / "config" / "smoke.yaml")
    with pytest.raises(CaptureWriteError) as e:
        twin.simulate_experiment(ROOT / "raw", "pi_p885", "ch3_sine_10hz", config, path)
    one_line(str(e.value), path, "file name too long (its name has 303 bytes")
    assert list(tmp_path.iterdir()) == []


# -- the reader, over arbitrary captures ---------------------------------------------------------

CODES = st.integers(-32768, 32767)
SCALES = st.one_of(
    st.sampled_from([0.0, -0.01, math.nan, math.inf, 1e305, 1e-300, 1e-31, 1e-30, 3e25]),
    st.floats(1e-12, 1e3),
)
MISSING_VALUES = st.one_of(
    st.none(),
    CODES,
    st.lists(CODES, min_size=1, max_size=3),
    st.sampled_from([-9999.5, 1e6, math.nan, "n/a"]),
)


@settings(
    max_examples=30, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(data=st.data())
def test_the_reader_counts_missing_exactly_or_stops_in_one_line(tmp_path, data):
    n = data.draw(st.integers(0, 40), label="n")
    fill = data.draw(st.one_of(st.none(), CODES), label="_FillValue")
    missing_value = data.draw(MISSING_VALUES, label="missing_value")
    scale = data.draw(SCALES, label="scale_factor")
    special = [c for c in (fill, NC_DEFAULT_FILL_I2, FILL, INT16_FULL, 0) if c is not None]
    codes = np.array(
        data.draw(st.lists(st.one_of(CODES, st.sampled_from(special)), min_size=n, max_size=n)),
        dtype=np.int16,
    )
    nan_at = data.draw(st.lists(st.integers(0, max(n - 1, 0)), max_size=5), label="NaN at")
    if n:
        codes[nan_at] = FILL
    path = tmp_path / f"h{data.draw(st.integers(0, 10**9))}.nc"
    with netCDF4.Dataset(path, "w") as nc:
        nc.fs = FS
        nc.createDimension("time", n)
        nc.createVariable("time", "f8", ("time",))[:] = np.arange(n) / FS
        var = nc.createVariable("U", "i2", ("time",), fill_value=fill)
        var.set_auto_maskandscale(False)
        var.setncatts({"units": "V", "scale_factor": scale, "add_offset": 0.0})
        if missing_value is not None:
            var.setncattr("missing_value", missing_value)  # as typed: text, NaN
        var[:] = codes
    try:
        scan = scan_capture(path)
        with open_capture(path) as cap:
            u = cap.read(["U"])["U"] if n else np.array([])
    except CaptureError as err:
        one_line(str(err), path)
        return
    marks = {FILL, NC_DEFAULT_FILL_I2 if fill is None else fill}
    declared = [] if missing_value is None else np.atleast_1d(missing_value)
    marks |= {int(v) for v in declared if float(v).is_integer() and abs(v) <= 32768}
    missing = np.isin(codes, list(marks))
    assert scan.nan == {"U": int(missing.sum())}
    assert scan.clipped == {"U": int((~missing & (np.abs(codes.astype(int)) == INT16_FULL)).sum())}
    assert np.array_equal(np.isnan(u), missing)
    np.testing.assert_array_equal(u[~missing], codes[~missing] * scale)
    assert n >= 2 and 1e-30 <= scale and scale * INT16_FULL <= 1e30
