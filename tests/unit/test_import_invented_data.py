"""`selfsense import` never makes up a sample (the Import rows of docs/reliability.md's fault
matrix): a MATLAB v7.3 variable declared longer than the data written is refused, a TDMS file
whose last segment was cut is cut to the samples it holds and says so, one column imported as
two channels is refused, and a --gain or --scale that leaves a channel a few int16 codes, or a
displacement no bench records, is refused naming the option. Each refusal is one line and leaves
nothing behind; the messages that named another cause than the real one name the real one.
"""

import logging
import tempfile
from pathlib import Path

import h5py
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from nptdms import ChannelObject, TdmsWriter
from scipy.io import savemat

from selfsense.io.capture import open_capture
from selfsense.io.importer import MIN_CODES

from ..helpers import ellipse, import_args, imports, refused, write_csv

FS = 1000.0
#: how often a property is tried: each example writes a file and imports it
EXAMPLES = settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])


def signal(n, phase=0.0):
    """A drive-like series that never holds one value: a sine through n samples at FS."""
    return 100 * np.sin(2 * np.pi * 5 * np.arange(n) / FS + phase)


def matlab_header(path):
    """MATLAB's 512-byte user block text (its save -v7.3 writes one)."""
    with open(path, "r+b") as raw:
        raw.write(b"MATLAB 7.3 MAT-file, Platform: GLNXA64, HDF5 schema 1.00 .".ljust(116))


def v73(path, variables):
    """A v7.3 file of {name: (shape as stored, chunks or None, [(index, values)])}: each dataset
    created at its declared shape and only the given slices written, as MATLAB's matfile writes
    a preallocated variable piece by piece."""
    with h5py.File(path, "w", userblock_size=512) as f:
        for name, (shape, chunks, writes) in variables.items():
            ds = f.create_dataset(name, shape=shape, dtype="f8", chunks=chunks)
            ds.attrs["MATLAB_class"] = np.bytes_("double")
            for where, values in writes:
                ds[where] = values
    matlab_header(path)
    return path


def read(capture, *channels):
    with open_capture(capture) as cap:
        return cap.read(list(channels)), cap.attrs, cap.n


# -- MATLAB v7.3: a variable declared longer than written ------------------------------------------


@EXAMPLES
@given(
    chunk=st.sampled_from([64, 256, 1000, 4096]),
    chunks_declared=st.integers(2, 12),
    written=st.floats(0.0, 1.0),
    layout=st.sampled_from(["row vector", "column vector", "matrix column"]),
    last_too=st.booleans(),
)
def test_a_v73_variable_written_short_of_its_declared_extent_is_refused(
    chunk, chunks_declared, written, layout, last_too
):
    n = chunk * chunks_declared - chunk // 3  # the last chunk reaches past the end
    m = int(written * n)
    full = signal(n)
    # the chunks the samples 0..m-1 fall in are written; a matfile preallocation also writes the
    # last sample (m.x(1, N) = 0), leaving the gap in the middle
    if layout == "matrix column":  # MATLAB's n×2 data, stored (2, n); the channel is data(:,2)
        shape, chunks, at, name = (2, n), (1, chunk), lambda s: (1, s), "data[2]"
        writes = [((0, slice(0, n)), signal(n, 1.0))]
    elif layout == "row vector":  # MATLAB's 1×n, stored (n, 1)
        shape, chunks, at, name = (n, 1), (chunk, 1), lambda s: (s, 0), "data"
        writes = []
    else:  # MATLAB's n×1, stored (1, n)
        shape, chunks, at, name = (1, n), (1, chunk), lambda s: (0, s), "data"
        writes = []
    if m:
        writes.append((at(slice(0, m)), full[:m]))
    if last_too:
        writes.append((at(slice(n - 1, n)), full[n - 1 :]))
    grid = -(-n // chunk)
    held = set(range(-(-m // chunk))) | ({grid - 1} if last_too else set())
    missing = [k for k in range(grid) if k not in held]
    with tempfile.TemporaryDirectory() as tmp:
        source = v73(Path(tmp) / "log.mat", {"data": (shape, chunks, writes)})
        args = import_args(source, Path(tmp) / "raw", f"U={name}:V", extra=["--fs", str(FS)])
        if not missing:  # every chunk holds a written sample: HDF5 stores no more to tell
            if m == n or (last_too and m == n - 1):
                capture, _ = imports(args)
                data, _, count = read(capture, "U")
                assert count == n and np.abs(data["U"] - full).max() < 0.01
            return  # else the unwritten tail of a written chunk, which no file tells (docs)
        start = missing[0] * chunk
        stop = next((k * chunk for k in range(missing[0], grid) if k in held), n)
        what = (
            f"none of its {n} samples was written"
            if (start, stop) == (0, n)
            else f"its samples {start + 1}–{stop} of {n} were never written"
        )
        message = refused(args, f"variable '{name}' (U): {what}", "fill value 0")
        assert ("at most its first" in message) == (stop == n and start > 0)


def test_a_v73_variable_never_written_is_refused_and_a_complete_one_imports(tmp_path):
    n = 3000
    source = v73(
        tmp_path / "run.mat",
        {
            "never": ((1, n), None, []),  # contiguous, no storage allocated
            "never_chunked": ((1, n), (1, 500), []),
            "whole": ((1, n), (1, 500), [(0, signal(n))]),
            "contiguous": ((1, n), None, [(0, signal(n))]),
        },
    )
    raw = tmp_path / "raw"
    for name in ("never", "never_chunked"):
        refused(
            import_args(source, raw, f"U={name}:V", extra=["--fs", str(FS)]),
            f"variable '{name}' (U): none of its {n} samples was written",
            "no HDF5 storage holds them",
        )
    for name in ("whole", "contiguous"):
        capture, _ = imports(
            import_args(source, raw, f"U={name}:V", experiment=name, extra=["--fs", str(FS)])
        )
        assert np.abs(read(capture, "U")[0]["U"] - signal(n)).max() < 0.01


# -- TDMS: a last segment cut short --------------------------------------------------------------


def tdms_two_segments(path, n):
    """Channels g/U and g/x, n samples each, in two segments (a DAQ's stream), contiguous."""
    u, x = signal(2 * n), 10 + signal(2 * n, 0.5) / 20
    with TdmsWriter(path) as writer:
        for part in (slice(0, n), slice(n, 2 * n)):
            props = {"wf_increment": 1 / FS}
            writer.write_segment(
                [
                    ChannelObject("g", "U", u[part], properties=props),
                    ChannelObject("g", "x", x[part], properties=props),
                ]
            )
    return u, x


@EXAMPLES
@given(lost=st.integers(1, 16 * 400 - 1), both=st.booleans())
def test_a_tdms_file_cut_in_its_last_segment_keeps_the_samples_it_holds_and_says_so(lost, both):
    n = 400
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        source = tmp / "cut.tdms"
        u, x = tdms_two_segments(source, n)
        data = source.read_bytes()
        source.write_bytes(data[: len(data) - lost])  # the last segment: U's n, then x's n values
        # what the file holds of each: 8 bytes a value, U's before x's in the segment
        left = 16 * n - lost
        held = {"U": n + min(n, left // 8), "x_laser": n + max(0, left - 8 * n) // 8}
        channels = ["U=g/U:V", *(["x_laser=g/x:um"] if both else [])]
        capture, _ = imports(import_args(source, tmp / "raw", *channels))
        expected = min(held["U"], held["x_laser"]) if both else held["U"]
        got, attrs, count = read(capture, "U", *(["x_laser"] if both else []))
        assert count == expected
        assert np.abs(got["U"] - u[:expected]).max() < 0.01  # the samples written, none made up
        if both:
            assert np.abs(got["x_laser"] - 1e-6 * x[:expected]).max() < 1e-9
        note = "the file's last segment is incomplete (its write was interrupted)"
        assert (
            f"{note}: imported the {expected} samples every channel holds" in (attrs["import_note"])
        )
        assert f"channel 'g/U' (U): {held['U']}" in attrs["import_note"]


def test_a_cut_tdms_file_is_said_once_and_a_complete_one_has_no_note(tmp_path, caplog):
    source = tmp_path / "run.tdms"
    tdms_two_segments(source, 400)
    whole = source.read_bytes()
    capture, _ = imports(import_args(source, tmp_path / "raw", "U=g/U:V", "x_laser=g/x:um"))
    assert "import_note" not in read(capture, "U")[1]
    assert not [r for r in caplog.records if r.levelno >= logging.WARNING]
    source.write_bytes(whole[:-100])
    capture, _ = imports(
        import_args(source, tmp_path / "raw", "U=g/U:V", "x_laser=g/x:um", experiment="cut")
    )
    assert read(capture, "U")[2] == 800 - 13  # x's last 100 bytes: 12.5 values
    said = [r for r in caplog.records if "last segment is incomplete" in r.getMessage()]
    # the import's line, once; nptdms' own warnings (three opens, two each) held back
    assert len(said) == 1 and not [r for r in caplog.records if r.name.startswith("nptdms")]


# -- one column under two channels -----------------------------------------------------------------


def test_one_column_imported_as_two_channels_is_refused_naming_both(tmp_path):
    csv = write_csv(tmp_path / "sine.csv")
    raw = tmp_path / "raw"
    refused(
        import_args(csv, raw, "U=U [V]:V", "x_laser=2:um", extra=["--time", "t [s]:s"]),
        "column 'U [V]' (U) and column 2 (x_laser) are one column of the file",
    )
    refused(
        import_args(csv, raw, "U=U [V]:V", extra=["--time", "2:s"]),
        "column 'U [V]' (U) and the time column 2 are one column of the file",
    )
    t, u, x = ellipse(periods=1)
    savemat(tmp_path / "v7.mat", {"data": np.column_stack([u, x])})
    refused(
        import_args(
            tmp_path / "v7.mat", raw, "U=data[1]:V", "x_laser=data[1]:um", extra=["--fs", "5000"]
        ),
        "variable 'data[1]' (U) and variable 'data[1]' (x_laser) are one variable of the file",
    )
    source = v73(tmp_path / "v73.mat", {"data": ((2, len(u)), None, [(slice(None), [u, x])])})
    refused(
        import_args(source, raw, "U=data[2]:V", "x_laser=data[2]:um", extra=["--fs", "5000"]),
        "variable 'data[2]' (U) and variable 'data[2]' (x_laser) are one variable of the file",
    )
    tdms = tmp_path / "run.tdms"
    tdms_two_segments(tdms, 400)
    refused(
        import_args(tdms, raw, "U=g/U:V", "x_laser=1:um"),
        "channel 'g/U' (U) and channel 'g/U' (x_laser) are one channel of the file",
    )
    capture, _ = imports(import_args(csv, raw, "U=U [V]:V", "x_laser=3:um", extra=["--fs", "5e3"]))
    assert capture.exists()  # two columns: imported


# -- a factor that leaves a channel a few codes, or a displacement no bench records ----------------


@EXAMPLES
@given(
    exponent=st.floats(-320, 2),
    negative=st.booleans(),
    option=st.sampled_from(["--gain", "--scale"]),
    given_range=st.booleans(),
)
def test_a_factor_that_leaves_a_channel_a_few_codes_is_refused_naming_it(
    exponent, negative, option, given_range
):
    factor = (-1.0 if negative else 1.0) * 10.0**exponent
    u = signal(2000)  # ±100 V as recorded
    span = 200 * abs(factor)
    if given_range:
        width = 400.0
    else:  # a range derived from the data: their span and a margin of a tenth of it (or of 1e-15)
        width = span + 0.2 * max(span, 1e-15)
    codes = min(span, width) / (width / 65534)
    if span > 0.99 * width or (not given_range and span / 2 > 1e4):
        return  # clipped, or no piezo drive: refused, but not for this test
    if abs(codes / MIN_CODES - 1) < 0.05:
        return  # the derived range's rounding decides
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        source = tmp / "run.csv"
        source.write_text("U\n" + "".join(f"{v!r}\n" for v in u.tolist()))
        extra = ["--fs", str(FS), option, f"U={factor!r}"]
        extra += ["--range", "U=-200,200"] if given_range else []
        args = import_args(source, tmp / "raw", "U=U:V", extra=extra)
        if codes < MIN_CODES:
            message = refused(args, f"fewer than {MIN_CODES}", "check the factor", starts=option)
            assert float(message.split(":")[0].split("=")[1]) == factor  # the flag as typed
            return
        capture, _ = imports(args)
        got = read(capture, "U")[0]["U"]
        assert len(np.unique(got)) >= MIN_CODES
        assert np.abs(got - factor * u).max() <= 0.6 * width / 65534


def test_gain_1e_minus_320_is_refused_before_anything_is_written(tmp_path):
    csv = write_csv(tmp_path / "sine.csv")
    refused(
        import_args(
            csv, tmp_path / "raw", "U=U [V]:V", extra=["--time", "t [s]:s", "--gain", "U=1e-320"]
        ),
        "U spans",
        "int16 codes of its range [-1e-16, 1e-16] V (derived from the data), fewer than "
        f"{MIN_CODES}",
        starts="--gain U=1e-320:",
    )
    # a micrometre column whose factor makes it vanish: the factor named, not the unit
    refused(
        import_args(
            csv,
            tmp_path / "raw",
            "x_laser=x [um]:um",
            extra=["--fs", "5000", "--scale", "x_laser=1e-320"],
        ),
        "x_laser spans 0 pm: less than any sensor tells from noise",
        starts="--scale x_laser=1e-320:",
    )


def test_a_factor_that_makes_a_displacement_no_bench_records_is_refused_naming_it(tmp_path):
    csv = write_csv(tmp_path / "sine.csv")
    raw = tmp_path / "raw"
    refused(
        import_args(
            csv, raw, "x_laser=x [um]:um", extra=["--fs", "5000", "--scale", "x_laser=1e3"]
        ),
        "x_laser spans 30 mm: not a piezo actuator's displacement (at most 10 mm) (without the "
        "factor it spans 30 µm); check the factor, or give --range x_laser=LOW,HIGH",
        starts="--scale x_laser=1000:",
    )
    refused(
        import_args(
            csv, raw, "x_laser=x [um]:um", extra=["--fs", "5000", "--scale", "x_laser=1e-6"]
        ),
        "x_laser spans 30 pm: less than any sensor tells from noise",
        starts="--scale x_laser=1e-06:",
    )
    # into a range given: the clipping names the range as given and the factor
    refused(
        import_args(
            csv,
            raw,
            "x_laser=x [um]:um",
            extra=["--fs", "5000", "--scale", "x_laser=100", "--range", "x_laser=0,1e-4"],
        ),
        "the ADC range [0, 0.0001] m (--range x_laser) is too narrow",
        "or --scale x_laser=100 is not their factor",
    )


def test_a_range_too_wide_for_the_data_is_refused_naming_where_it_came_from(tmp_path):
    csv = write_csv(tmp_path / "sine.csv")
    raw = tmp_path / "raw"
    refused(
        import_args(csv, raw, "U=U [V]:V", extra=["--fs", "5000", "--range", "U=-1e6,1e6"]),
        f"column 'U [V]' (U): U spans 9.83 of the 65534 int16 codes of its range [-1e+06, 1e+06] "
        f"V (--range U), fewer than {MIN_CODES}",
        "give a range that fits the data",
    )


# -- the messages that named another cause than the real one ---------------------------------------


def lines_of(t, u, x):
    return "".join(
        f"{a!r},{b!r},{c!r}\n" for a, b, c in zip(t.tolist(), u.tolist(), (x * 1e6).tolist())
    )


@pytest.mark.parametrize(
    "name,text,channels,extra,fragments",
    [
        (
            "title.csv",
            "# exported by LabVIEW 2019\nt,U,x\n{rows}",
            ["U=U:V"],
            ["--time", "t:s"],
            [
                "its first line ('# exported by LabVIEW 2019') is one field, the lines after it "
                "split into 3 at ','",
                "a title or comment above the table: remove the lines above the header",
            ],
        ),
        (
            "title_no_header.csv",
            "Run 3 of 2024\n{rows}",
            ["U=2:V"],
            ["--fs", "5000", "--no-header"],
            ["its first line ('Run 3 of 2024') is one field", "remove the lines above the data"],
        ),
        (  # the title shares only the spaces with the rows: it once made ' ' the separator
            "title_spaced.csv",
            "Run 3 of 2024\nt, U, x\n{spaced}",
            ["U=U:V"],
            ["--time", "t:s"],
            ["its first line ('Run 3 of 2024') is one field, the lines after it split into 3"],
        ),
        (
            "cut.csv",
            "t,U,x\n{rows}0.7,1.5",
            ["U=U:V"],
            ["--time", "t:s"],
            [
                "the last data row has 2 fields where the rows before it have 3: the file ends "
                "inside a row, as an interrupted write leaves it"
            ],
        ),
        (
            "header.csv",
            "t,U,x\n{rows}",
            ["U=2:V"],
            ["--fs", "5000", "--no-header"],
            [
                "column 2 (U) holds 'U' in its first row and numbers below it: the file has a "
                "header row: leave --no-header out"
            ],
        ),
    ],
)
def test_a_text_file_refusal_names_the_real_cause(tmp_path, name, text, channels, extra, fragments):
    source = tmp_path / name
    rows = lines_of(*ellipse(periods=1))
    source.write_text(text.format(rows=rows, spaced=rows.replace(",", ", ")))
    refused(import_args(source, tmp_path / "raw", *channels, extra=extra), *fragments)


@pytest.mark.parametrize(
    "channel,fragment",
    [
        ("U=data.x:V", "'data.x': data is not a struct (no field 'x')"),
        ("U=data.T:V", "'data.T': data is not a struct (no field 'T')"),  # never numpy's .T
        ("U=runs.Data:V", "'runs.Data': runs is a struct array of 2 elements: name one"),
        (
            "U=vec[1]:V",
            "'vec[1]': vec is a vector of 5000 samples, not a matrix: name it without [1]",
        ),
    ],
)
def test_a_v7_path_through_a_variable_names_what_the_variable_is(tmp_path, channel, fragment):
    t, u, x = ellipse(periods=1)
    runs = np.zeros((2,), dtype=[("Data", object)])
    runs[0]["Data"], runs[1]["Data"] = u, x
    savemat(tmp_path / "v7.mat", {"data": np.column_stack([u, x]), "vec": u, "runs": runs})
    refused(
        import_args(tmp_path / "v7.mat", tmp_path / "raw", channel, extra=["--fs", "5000"]),
        fragment,
    )


def test_a_v73_array_of_three_dimensions_names_what_is_read(tmp_path):
    with h5py.File(tmp_path / "cube.mat", "w", userblock_size=512) as f:
        f.create_dataset("cube", data=np.ones((2, 3, 500)))
    refused(
        import_args(tmp_path / "cube.mat", tmp_path / "raw", "U=cube:V", extra=["--fs", "5000"]),
        "'cube' has 3 dimensions (500×3×2): the import reads a vector or a matrix's column",
    )


def test_an_empty_tdms_channel_is_named_not_a_length_mismatch(tmp_path):
    source = tmp_path / "empty.tdms"
    with TdmsWriter(source) as writer:
        writer.write_segment(
            [
                ChannelObject("g", "U", signal(500), properties={"wf_increment": 1 / FS}),
                ChannelObject("g", "x", np.array([], dtype=float)),
            ]
        )
    refused(
        import_args(source, tmp_path / "raw", "U=g/U:V", "x_laser=g/x:um"),
        "channel 'g/x' (x_laser) holds no data (the file lists it without values)",
    )
