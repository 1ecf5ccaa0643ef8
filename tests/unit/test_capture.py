"""The capture contract: round trip, atomic writes, and every validation failure in one line."""

import netCDF4
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from selfsense.io.capture import (
    FILL,
    CaptureError,
    CaptureWriter,
    channel_spec,
    compression_of,
    folded_fs,
    open_capture,
    scan_capture,
)

FS = 48000.0


def write(path, n=4800, attrs=None, values=None, channels=("U", "I"), **kw):
    specs = [channel_spec(c, -200.0, 200.0) for c in channels]
    attrs = {"fs": FS, "fr_nominal": 1e5, "ns": 12, "nf": 4} | (attrs or {})
    with CaptureWriter(path, attrs, specs, n, **kw) as w:
        for start in range(0, n, 1000):
            m = min(1000, n - start)
            chunk = {
                c: (values[start : start + m] if values is not None else np.linspace(0, 100, m))
                for c in channels
            }
            w.write(chunk)
    return path


def one_line(excinfo, path, *fragments):
    msg = str(excinfo.value)
    assert "\n" not in msg
    assert msg.startswith(str(path))
    for f in fragments:
        assert f in msg, msg


def test_round_trip_quantises_like_a_16_bit_adc(tmp_path):
    values = np.sin(np.arange(4800) / 50) * 150
    path = write(tmp_path / "c.nc", values=values)
    with open_capture(path, require=["U"]) as cap:
        back = cap.read(["U"])["U"]
        assert cap.n == 4800 and cap.fs == FS
    lsb = 400.0 / 65534
    assert np.max(np.abs(back - values)) <= lsb / 2 + 1e-12


def test_chunked_reading_equals_whole_reading(tmp_path):
    path = write(tmp_path / "c.nc", values=np.random.default_rng(1).uniform(-100, 100, 4800))
    with open_capture(path) as cap:
        whole = cap.read(["U", "I"])
        parts = [chunk for _, chunk in cap.iter_chunks(["U", "I"], chunk_len=777)]
    np.testing.assert_array_equal(np.concatenate([p["U"] for p in parts]), whole["U"])


def test_storage_is_packed_int16_with_cf_attributes(tmp_path):
    path = write(tmp_path / "c.nc")
    with netCDF4.Dataset(path) as nc:
        v = nc["U"]
        assert v.dtype == np.int16 and v.units == "V"
        assert {"scale_factor", "add_offset"} <= set(v.ncattrs())
        assert (
            compression_of(v) == "zlib"
            and v.filters()["fletcher32"]
            and v.chunking() != "contiguous"
        )
        assert nc.Conventions.startswith("CF")


def test_interrupted_writer_leaves_nothing(tmp_path):
    path = tmp_path / "c.nc"
    with pytest.raises(RuntimeError):
        with CaptureWriter(path, {"fs": FS}, [channel_spec("U", -1, 1)], 100) as w:
            w.write({"U": np.zeros(50)})
            raise RuntimeError("killed")
    assert list(tmp_path.iterdir()) == []


def test_writer_stopping_early_is_an_error_and_leaves_nothing(tmp_path):
    path = tmp_path / "c.nc"
    with pytest.raises(ValueError, match="stopped early"):
        with CaptureWriter(path, {"fs": FS}, [channel_spec("U", -1, 1)], 100) as w:
            w.write({"U": np.zeros(50)})
    assert list(tmp_path.iterdir()) == []


def test_nan_and_clipping_are_counted(tmp_path):
    values = np.zeros(4800)
    values[100:110] = np.nan
    values[200:203] = 500.0  # beyond the ±200 V ADC range
    path = write(tmp_path / "c.nc", values=values)
    scan = scan_capture(path)
    assert scan.nan["U"] == 10 and scan.clipped["U"] == 3


def test_truncated_file(tmp_path):
    path = write(tmp_path / "c.nc", n=48000)
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])
    with pytest.raises(CaptureError) as e:
        scan_capture(path)
    one_line(e, path)


def test_not_a_netcdf_file(tmp_path):
    path = tmp_path / "c.nc"
    path.write_text("time,U\n0,1\n")
    with pytest.raises(CaptureError) as e:
        open_capture(path)
    one_line(e, path, "not a readable netCDF4 capture")


def test_missing_channel(tmp_path):
    path = write(tmp_path / "c.nc")
    with pytest.raises(CaptureError) as e:
        open_capture(path, require=["U", "Ur"])
    one_line(e, path, "missing channel(s) Ur")


def test_wrong_units(tmp_path):
    path = write(tmp_path / "c.nc")
    with netCDF4.Dataset(path, "a") as nc:
        nc["U"].units = "mV"
    with pytest.raises(CaptureError) as e:
        open_capture(path)
    one_line(e, path, "channel U has units 'mV'")


def test_empty_capture(tmp_path):
    path = tmp_path / "c.nc"
    with CaptureWriter(path, {"fs": FS}, [channel_spec("U", -1, 1)], 0):
        pass
    with pytest.raises(CaptureError) as e:
        open_capture(path)
    one_line(e, path, "empty capture")


def test_time_axis_with_a_gap(tmp_path):
    path = write(tmp_path / "c.nc")
    with netCDF4.Dataset(path, "a") as nc:
        t = nc["time"][:]
        t[2000:] += 0.01
        nc["time"][:] = t
    with pytest.raises(CaptureError) as e:
        open_capture(path)
    one_line(e, path, "gap or wrong fs")


def test_gap_in_the_middle_is_found_while_streaming(tmp_path):
    path = write(tmp_path / "c.nc")
    with netCDF4.Dataset(path, "a") as nc:
        t = nc["time"][:]
        t[2000:2100] += 0.5  # endpoints intact: only a streaming check sees it
        nc["time"][:] = t
    with pytest.raises(CaptureError) as e:
        scan_capture(path)
    one_line(e, path, "time axis breaks at sample 2000")


def test_wrong_fs_attribute(tmp_path):
    path = write(tmp_path / "c.nc")
    with netCDF4.Dataset(path, "a") as nc:
        nc.fs = 50000.0
    with pytest.raises(CaptureError) as e:
        open_capture(path)
    one_line(e, path, "fs = 50000")


def test_fs_that_violates_the_folding_equation(tmp_path):
    path = write(tmp_path / "c.nc", attrs={"fs": 47000.0})
    with pytest.raises(CaptureError) as e:
        open_capture(path)
    one_line(e, path, "folding equation", "need fs = 48000")


@pytest.mark.parametrize(
    "ns,nf,fs", [(4, 0, 400e3), (4, 2, 80e3), (4, 12, 16e3), (12, 0, 1200e3), (12, 4, 48e3)]
)
def test_folding_equation_matches_table_3_1(ns, nf, fs):
    assert folded_fs(100e3, ns, nf) == pytest.approx(fs)


@settings(max_examples=50, deadline=None)
@given(
    values=st.lists(
        st.one_of(st.floats(-30.0, 30.0), st.just(float("nan"))), min_size=1, max_size=50
    )
)
def test_quantize_equals_unpacking_the_packed_codes(values):
    spec = channel_spec("U", -20.0, 20.0)
    codes, _ = spec.pack(np.array(values))
    unpacked = np.where(codes == FILL, np.nan, codes * spec.scale_factor + spec.add_offset)
    np.testing.assert_array_equal(spec.quantize(np.array(values)), unpacked)


@pytest.mark.parametrize("compression", ["zlib", "zstd", "blosc_lz4", "blosc_zstd", None])
def test_every_allowed_compression_round_trips_and_the_written_scan_is_the_read_one(
    tmp_path, compression
):
    values = np.sin(np.arange(48000) / 50) * 150  # smooth: compressible by every codec
    values[100:110] = np.nan
    values[200:203] = 500.0
    specs = [channel_spec(c, -200.0, 200.0) for c in ("U", "I")]
    with CaptureWriter(
        tmp_path / "c.nc",
        {"fs": FS},
        specs,
        len(values),
        compression=compression,
        complevel=3,
        chunk_len=4096,
    ) as w:
        for start in range(0, len(values), 5000):
            w.write({c: values[start : start + 5000] for c in ("U", "I")})
    with netCDF4.Dataset(w.path) as nc:
        assert compression_of(nc["U"]) == compression
    assert w.scan_report() == scan_capture(w.path)
    with open_capture(w.path) as cap:
        np.testing.assert_array_equal(
            cap.read(["U"])["U"], specs[0].quantize(values)
        )  # NaN kept, 500 V clipped


def test_a_chunk_blosc_cannot_shrink_is_one_line_and_leaves_nothing(tmp_path):
    noise = np.random.default_rng(1).uniform(-200, 200, 4096)  # 16 bits of entropy per sample
    with pytest.raises(CaptureError) as e:
        with CaptureWriter(
            tmp_path / "c.nc",
            {"fs": FS},
            [channel_spec("U", -200, 200)],
            4096,
            compression="blosc_zstd",
            complevel=3,
        ) as w:
            w.write({"U": noise})
    one_line(e, tmp_path / "c.nc", "blosc", "zlib stores any data")
    assert list(tmp_path.iterdir()) == []


def test_a_compression_outside_the_contract_is_refused_on_open(tmp_path):
    path = write(tmp_path / "c.nc")
    with netCDF4.Dataset(path, "a") as nc:
        v = nc.createVariable("Ur", "i2", ("time",), compression="bzip2")
        v.setncatts({"units": "V", "scale_factor": 0.01, "add_offset": 0.0})
    with pytest.raises(CaptureError) as e:
        open_capture(path)
    one_line(e, path, "channel Ur is compressed with bzip2")


def test_what_lands_on_disk_differing_from_what_was_written_is_never_renamed(tmp_path, monkeypatch):
    flush = CaptureWriter._flush

    def landing_wrong(self, name):  # a storage error after the CRC was taken
        start = self._queued.get(name, (None,))[0]
        flush(self, name)
        if name == "I" and start == 0:
            self._nc[name][1] = self._nc[name][1] + 1

    monkeypatch.setattr(CaptureWriter, "_flush", landing_wrong)
    with pytest.raises(CaptureError) as e:
        write(tmp_path / "c.nc")
    one_line(e, tmp_path / "c.nc", "not renamed into place: variable I read back differs")
    assert list(tmp_path.iterdir()) == []
