"""`selfsense import` of a lab's real recordings ("A lab's real recordings"): a LabVIEW DAQ's
headerless, tab-separated, time-less file, columns counted from 1 as people count them, the
amplifier's monitor and a sensor's volts scaled (--gain, --scale) and the scaling recorded;
NI TDMS and MATLAB v7.3 (HDF5) files streamed like the CSV. The slips a new user makes (a
position counted from 0, a constant column, µm read as m, the wrong separator) stop with one line
that says what to type instead, and leave nothing behind.
"""

import logging
import re
import warnings

import h5py
import numpy as np
import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from nptdms import ChannelObject, GroupObject, TdmsWriter
from scipy.io import savemat

from selfsense.cli import main as cli
from selfsense.io.capture import open_capture
from selfsense.io.csv_source import detect_separator
from selfsense.io.importer import PLAUSIBLE, Request, run_import
from selfsense.io.manifest import (
    ManifestError,
    channel_scalings,
    load_dataset,
    validate_document,
)
from selfsense.io.sources import ImportProblem, parse_column

from ..helpers import import_args, imports, refused

FS = 200.0
N = 4000


def daq_columns(n=N, fs=FS):
    """The LabVIEW file's six columns: a constant 1 (a status word), the amplifier's 1/20
    monitor of a ±150 V drive [V], a second input, an idle input at 0, a constant 12 (a
    thermocouple's cold junction), the displacement sensor's volts at 10 µm/V."""
    t = np.arange(n) / fs
    return [
        np.full(n, 1.0),
        7.5 * np.sin(2 * np.pi * t),
        np.sin(2 * np.pi * 3 * t),
        np.zeros(n),
        np.full(n, 12.0),
        3.0 + 3.0 * np.sin(2 * np.pi * t - 0.1),
    ]


def write_table(path, columns, sep="\t", header=None):
    lines = [sep.join(header)] if header else []
    lines += [sep.join(f"{c[i]:.6f}" for c in columns) for i in range(len(columns[0]))]
    path.write_text("\n".join(lines) + "\n")
    return path


def read(capture, *channels):
    with open_capture(capture) as cap:
        return cap.read(list(channels)), cap.attrs, {c: cap.resolution(c) for c in channels}, cap


# -- the file: headerless, tab-separated, no time ------------------------------------------


@pytest.mark.parametrize("sep", ["tab", "\\t", "\t"])
def test_a_headerless_tab_separated_daq_file_imports_scaled_with_columns_counted_from_1(
    tmp_path, sep
):
    columns = daq_columns()
    source = write_table(tmp_path / "run3.txt", columns)
    args = import_args(
        source,
        tmp_path / "raw",
        "U=2:V",
        "x_disp=6:um",
        extra=["--fs", "200", "--no-header", "--sep", sep, "--gain", "U=20"]
        + ["--scale", "x_disp=10"],
    )
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no pandas ParserWarning: the C engine reads a tab
        capture, _ = imports(args)
    data, attrs, step, cap = read(capture, "U", "x_disp")
    assert cap.fs == FS and cap.n == N
    assert np.abs(data["U"] - 20 * columns[1]).max() <= step["U"]  # ±150 V at the actuator
    assert np.abs(data["x_disp"] - 10e-6 * columns[5]).max() <= step["x_disp"]  # 0…60 µm
    assert (attrs["scale_U"], attrs["scale_kind_U"]) == (20.0, "gain")
    assert (attrs["scale_x_disp"], attrs["scale_kind_x_disp"]) == (10.0, "sensitivity")
    manifest = load_dataset(tmp_path / "raw", "lab")
    assert manifest["sensors"] == {
        "U": {"scale": 20.0, "scale_kind": "gain"},
        "x_disp": {"scale": 10.0, "scale_kind": "sensitivity"},
    }
    lo, hi = manifest["daq"]["ranges"]["U"]
    assert lo < -150 and hi > 150 and hi - lo < 1.5 * 300  # derived from the scaled values
    assert channel_scalings(manifest) == {
        "U": "20 × logged (gain)",
        "x_disp": "10 × logged (sensitivity)",
    }


def test_channel_scalings_label_each_scaled_channel_and_nothing_else():
    assert channel_scalings({"daq": {}}) == {}
    manifest = {"sensors": {"U": {"scale": -2.5, "scale_kind": "gain"}, "x_laser": {"type": "v"}}}
    assert channel_scalings(manifest) == {"U": "-2.5 × logged (gain)"}


@pytest.mark.parametrize(
    "sensor,fragment",
    [
        ({"scale": 20.0}, "key sensors.U: 'scale_kind' is a dependency of 'scale'"),
        ({"scale": 0, "scale_kind": "gain"}, "key sensors.U.scale: 0 should not be valid"),
        ({"scale": 2.0, "scale_kind": "amp"}, "'amp' is not one of ['gain', 'sensitivity']"),
    ],
)
def test_the_manifest_schema_takes_a_scale_with_its_kind_only(sensor, fragment):
    doc = {
        "name": "lab",
        "description": "x",
        "source": "measured",
        "daq": {"fs": 200.0, "channels": ["U"], "ranges": {"U": [-200, 200]}},
        "protocols": [],
        "sensors": {"U": {"type": "monitor", "scale": 20.0, "scale_kind": "gain"}},
    }
    validate_document(doc, "dataset.schema.yaml", "dataset.yaml")
    doc["sensors"]["U"] = sensor
    with pytest.raises(ManifestError, match=re.escape(fragment)):
        validate_document(doc, "dataset.schema.yaml", "dataset.yaml")


def test_a_position_counted_from_0_stops_with_the_one_to_type(tmp_path, capsys):
    with pytest.raises(ImportProblem, match=r"columns are counted from 1.*\(type U=1:V\)"):
        parse_column("U=0:V")
    with pytest.raises(ImportProblem, match=r"the first column is 1 \(type 1:s\)"):
        parse_column("0:s", time=True)
    source = write_table(tmp_path / "run3.txt", daq_columns())
    args = import_args(source, tmp_path / "raw", "U=0:V", extra=["--fs", "200", "--no-header"])
    with pytest.raises(SystemExit) as exit_:  # argparse refuses the argument: usage, one line
        cli(args)
    assert exit_.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert "columns are counted from 1" in err[-1] and "type U=1:V" in err[-1]
    assert not (tmp_path / "raw").exists()
    # a position past the last column
    args = import_args(source, tmp_path / "raw", "U=7:V", extra=["--fs", "200", "--no-header"])
    refused(args, "column 7 for U does not exist (the file has 6 columns, counted from 1)")


def test_a_constant_column_is_refused_naming_the_columns_that_vary(tmp_path):
    source = write_table(tmp_path / "run3.txt", daq_columns())
    # the slip: U=1 and x_disp=5 meant the second and sixth, counted from 0
    args = import_args(
        source, tmp_path / "raw", "U=1:V", "x_disp=5:um", extra=["--fs", "200", "--no-header"]
    )
    refused(
        args,
        f"column 1 (U) holds one value (1) in all {N} rows: not a measurement",
        "columns are counted from 1: the columns that vary are 2, 3, 6",
    )
    args = import_args(
        source, tmp_path / "raw", "U=2:V", "x_disp=5:um", extra=["--fs", "200", "--no-header"]
    )
    refused(args, "column 5 (x_disp) holds one value (12)", "the columns that vary are 2, 3, 6")
    # with a header the varying columns carry their names
    header = ["status", "U mon [V]", "aux", "idle", "cj [C]", "x [V]"]
    named = write_table(tmp_path / "named.txt", daq_columns(), header=header)
    refused(
        import_args(named, tmp_path / "raw", "U=idle:V", extra=["--fs", "200"]),
        "column 'idle' (U) holds one value (0)",
        "2 (U mon [V]), 3 (aux), 6 (x [V])",
    )


def test_a_header_name_made_of_digits_is_written_with_a_hash(tmp_path, caplog):
    t = np.arange(400) / FS
    u, x = 100 * np.sin(2 * np.pi * t), 20 + 10 * np.sin(2 * np.pi * t)
    # LabVIEW names its columns by channel number: the column named 1 is the third
    source = write_table(tmp_path / "n.csv", [t, x, u], sep=",", header=["t", "0", "1"])
    capture, _ = imports(
        import_args(source, tmp_path / "raw", "U=#1:V", "x_laser=2:um", extra=["--time", "1:s"])
    )
    data, _, step, _ = read(capture, "U", "x_laser")
    assert np.abs(data["U"] - u).max() <= step["U"]
    assert np.abs(data["x_laser"] - 1e-6 * x).max() <= step["x_laser"]
    # digits are a position; a column named so elsewhere is pointed out (--time 1: the column
    # named 1 is the third)
    said = [r.getMessage() for r in caplog.records if "is named" in r.getMessage()]
    assert (
        said
        and "--time 1:s is the file's column 1; the header's column 3 is named '1': type '#1:s'"
        in said[0]
    )
    caplog.clear()
    with caplog.at_level(logging.WARNING, logger="selfsense.io.importer"):
        imports(
            import_args(source, tmp_path / "raw", "U=3:V", experiment="two", extra=["--fs", "200"])
        )
    # U=3 is the third column: no column elsewhere is named 3
    assert not [r for r in caplog.records if "is named" in r.getMessage()]
    with caplog.at_level(logging.WARNING, logger="selfsense.io.importer"):
        imports(
            import_args(
                source, tmp_path / "raw", "U=1:V", experiment="three", extra=["--fs", "200"]
            )
        )
    said = [r.getMessage() for r in caplog.records if "is named" in r.getMessage()]
    assert said and "the header's column 3 is named '1': type 'U=#1:V'" in said[0]


# -- plausibility of a first import ----------------------------------------------------------------


def test_micrometres_read_as_metres_stop_a_first_import_suggesting_um_and_range(tmp_path):
    columns = daq_columns()
    columns[5] = 24.7 + 24.7 * np.sin(np.arange(N) / FS)  # µm: stroke 49.4
    source = write_table(tmp_path / "run3.txt", columns)
    base = ["--fs", "200", "--no-header", "--gain", "U=20"]
    refused(
        import_args(source, tmp_path / "raw", "U=2:V", "x_disp=6:m", extra=base),
        "x_disp spans 49.4 m: not a piezo actuator's displacement (at most 10 mm)",
        "if the column is in um type x_disp=6:um, or give --range x_disp=LOW,HIGH to keep it",
    )
    # the suggestion imports
    capture, _ = imports(import_args(source, tmp_path / "raw", "U=2:V", "x_disp=6:um", extra=base))
    data, *_ = read(capture, "x_disp")
    assert abs(np.ptp(data["x_disp"]) - 49.4e-6) < 1e-8
    # a range given declares it: the check is skipped (the user has said so)
    capture, _ = imports(
        import_args(
            source,
            tmp_path / "raw",
            "U=2:V",
            "x_disp=6:m",
            dataset="metres",
            extra=[*base, "--range", "x_disp=-1,60"],
        )
    )
    assert abs(np.ptp(read(capture, "x_disp")[0]["x_disp"]) - 49.4) < 0.01


@pytest.mark.parametrize(
    "channel,unit,values,fragments",
    [
        pytest.param(
            "U",
            "kV",
            150 * np.sin(np.arange(N) / 50),
            ["U reaches 150 kV: not a piezo drive's voltage (at most 10 kV)", "type U=1:V"],
            id="volts read as kV",
        ),
        pytest.param(
            "x_laser",
            "nm",
            2e-5 * np.sin(np.arange(N) / 50),
            [
                "x_laser spans 0.04 pm: less than any sensor tells from noise for a piezo "
                "actuator's displacement (at least 100 pm)",
                "if the column is in m type x_laser=1:m",
            ],
            id="metres read as nm",
        ),
        pytest.param(
            "I",
            "A",
            500 * np.sin(np.arange(N) / 50),
            ["I reaches 500 A: not a piezo drive's current (at most 100 A)", "type I=1:mA"],
            id="mA read as A",
        ),
        pytest.param(
            "F",
            "kN",
            5e3 * np.sin(np.arange(N) / 50),
            ["F reaches 5 MN: not a force on a piezo actuator (at most 1 MN)", "type F=1:N"],
            id="N read as kN",
        ),
    ],
)
def test_an_implausible_unit_is_refused_naming_the_unit_that_fits(
    tmp_path, channel, unit, values, fragments
):
    source = write_table(tmp_path / "one.txt", [values, np.sin(np.arange(N) / 7)])
    refused(
        import_args(source, tmp_path / "raw", f"{channel}=1:{unit}", extra=["--fs", "200"]),
        *fragments,
        f"--range {channel}=LOW,HIGH",
    )


def test_the_plausibility_table_states_each_limit():
    assert PLAUSIBLE["V"].peak == 1e4 and PLAUSIBLE["A"].peak == 100.0
    assert PLAUSIBLE["m"].span == (1e-10, 1e-2) and PLAUSIBLE["N"].peak == 1e6


# -- separators ------------------------------------------------------------------------------------


def test_a_tab_file_without_sep_is_detected_and_a_pipe_file_names_its_sep(tmp_path, caplog):
    columns = daq_columns()
    source = write_table(tmp_path / "run3.txt", columns)
    args = import_args(
        source, tmp_path / "raw", "U=2:V", extra=["--fs", "200", "--no-header", "--gain", "U=20"]
    )
    with caplog.at_level(logging.INFO, logger="selfsense.io.importer"):
        capture, _ = imports(args)
    notes = [r.getMessage() for r in caplog.records if "detected" in r.getMessage()]
    assert notes == [f"{source}: separator tab detected (--sep to choose another)"]
    assert np.abs(read(capture, "U")[0]["U"] - 20 * columns[1]).max() < 0.01
    piped = write_table(tmp_path / "pipe.txt", columns, sep="|")
    raw = tmp_path / "raw2"
    refused(
        import_args(piped, raw, "U=2:V", extra=["--fs", "200", "--no-header"]),
        "no comma, semicolon or tab splits its rows alike: give --sep, e.g. --sep '|'",
    )
    spaced = write_table(tmp_path / "space.txt", columns, sep=" ", header=list("abcdef"))
    refused(
        import_args(spaced, raw, "U=2:V", extra=["--fs", "200"]),
        "give --sep, e.g. --sep ' '",
    )
    # a separator given that leaves each row one field, where tab splits it
    refused(
        import_args(source, raw, "U=2:V", extra=["--fs", "200", "--sep", ","]),
        "separator ',' leaves each row one field; tab splits them into 6: type --sep tab",
    )


def test_semicolons_win_over_decimal_commas(tmp_path):
    t = np.arange(400) / FS
    u = 100 * np.sin(2 * np.pi * t)
    lines = ["t;U"] + [f"{a:.4f};{b:.4f}".replace(".", ",") for a, b in zip(t, u)]
    assert detect_separator(tmp_path / "x", lines[:10]) == ";"
    assert detect_separator(tmp_path / "x", [line for line in lines[1:10]]) == ";"


NUMBER = st.one_of(
    st.floats(-1e6, 1e6, allow_nan=False, allow_infinity=False).map(repr),
    st.integers(-(10**6), 10**6).map(str),
)


@settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    sep=st.sampled_from(["\t", ";", ","]),
    width=st.integers(2, 8),
    rows=st.integers(1, 12),
    header=st.booleans(),
    data=st.data(),
)
def test_the_separator_of_any_numeric_table_is_detected(
    tmp_path_factory, sep, width, rows, header, data
):
    table = [data.draw(st.lists(NUMBER, min_size=width, max_size=width)) for _ in range(rows)]
    lines = ([sep.join(f"c {j}" for j in range(width))] if header else []) + [
        sep.join(r) for r in table
    ]
    assert detect_separator(tmp_path_factory.getbasetemp(), lines[:10]) == sep


@settings(max_examples=10, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(sep=st.sampled_from(["\t", ";", ","]), seed=st.integers(0, 2**16))
def test_a_table_without_sep_imports_as_with_it(tmp_path_factory, sep, seed):
    folder = tmp_path_factory.mktemp("sep")
    rng = np.random.default_rng(seed)
    u = rng.uniform(-100, 100, 50)
    source = write_table(folder / "rec.dat", [np.arange(50) / FS, u], sep=sep, header=["t", "U"])
    capture, _ = imports(import_args(source, folder / "raw", "U=2:V", extra=["--time", "t:s"]))
    data, _, step, cap = read(capture, "U")
    assert cap.fs == FS and np.abs(data["U"] - np.round(u, 6)).max() <= step["U"]


# -- one scaling per channel and dataset -----------------------------------------------------------


def test_a_second_import_with_another_gain_for_a_channel_is_refused(tmp_path):
    source = write_table(tmp_path / "run3.txt", daq_columns())
    base = ["--fs", "200", "--no-header"]
    raw = tmp_path / "raw"
    imports(import_args(source, raw, "U=2:V", extra=[*base, "--gain", "U=20"]))
    refused(
        import_args(source, raw, "U=2:V", experiment="again", extra=[*base, "--gain", "U=10"]),
        "sensors.U declares scale 20 (gain), this import --gain U=10",
        "type --gain U=20",
        starts=raw / "lab" / "dataset.yaml",
    )
    refused(
        import_args(source, raw, "U=2:V", experiment="again", extra=[*base, "--scale", "U=20"]),
        "this import --scale U=20",
        "type --gain U=20",
        starts=raw / "lab" / "dataset.yaml",
    )
    refused(
        import_args(source, raw, "U=2:V", experiment="again", extra=base),
        "this import U unscaled",
        "type --gain U=20",
        starts=raw / "lab" / "dataset.yaml",
    )
    # the same gain: imported, the manifest's declaration unchanged
    imports(import_args(source, raw, "U=2:V", experiment="again", extra=[*base, "--gain", "U=20"]))
    manifest = load_dataset(raw, "lab")
    assert manifest["experiments"] == ["run", "again"]
    assert manifest["sensors"] == {"U": {"scale": 20.0, "scale_kind": "gain"}}
    # a channel declared unscaled keeps it
    imports(import_args(source, raw, "x_disp=6:um", dataset="plain", extra=base))
    refused(
        import_args(
            source,
            raw,
            "x_disp=6:um",
            dataset="plain",
            experiment="again",
            extra=[*base, "--scale", "x_disp=10"],
        ),
        "--scale x_disp=10: ",
        "declares x_disp unscaled",
        starts="--scale x_disp=10",
    )


@pytest.mark.parametrize(
    "extra,fragments,starts",
    [
        (["--gain", "U=0"], ["expected CHANNEL=FACTOR", "nonzero"], None),
        (["--gain", "U=nan"], ["finite, nonzero"], None),
        (["--scale", "Q=2"], ["a contract channel"], None),
        (["--gain", "x_disp=2"], ["no --channel x_disp to apply it to"], "--gain x_disp=2"),
        (
            ["--gain", "U=2", "--scale", "U=3"],
            ["U has a factor already: give one --scale or --gain per channel"],
            "--gain U=2",
        ),
        (["--attr", "scale_U=3"], ["set by the import itself (--scale or --gain)"], "--attr"),
    ],
)
def test_a_bad_factor_is_one_line_naming_the_option(tmp_path, capsys, extra, fragments, starts):
    source = write_table(tmp_path / "run3.txt", daq_columns())
    args = import_args(
        source, tmp_path / "raw", "U=2:V", extra=["--fs", "200", "--no-header", *extra]
    )
    if starts is None:  # argparse's own refusal of the argument
        with pytest.raises(SystemExit) as exit_:
            cli(args)
        assert exit_.value.code == 2
        line = capsys.readouterr().err.strip().splitlines()[-1]
        assert all(f in line for f in fragments), line
        assert not (tmp_path / "raw").exists()
        return
    refused(args, *fragments, starts=starts)


# -- NI TDMS ---------------------------------------------------------------------------------------


def write_tdms(path, increment=1 / FS, n=N, extra=()):
    columns = daq_columns(n)
    props = {"wf_increment": increment, "wf_start_offset": 0.0} if increment else {}
    with TdmsWriter(path) as writer:
        half = n // 2  # two segments: a stream written as the DAQ went
        for part in (slice(0, half), slice(half, n)):
            writer.write_segment(
                [
                    GroupObject("Untitled"),  # groups in this order (nptdms sorts the ones it adds)
                    GroupObject("Other group"),
                    ChannelObject("Untitled", "Dev1/ai0", columns[1][part], properties=props),
                    ChannelObject("Untitled", "aux in", columns[2][part], properties=props),
                    ChannelObject("Other group", "aux in", columns[3][part], properties=props),
                    ChannelObject("Untitled", "x disp", columns[5][part], properties=props),
                    *extra,
                ]
            )
    return path, columns


def test_a_tdms_file_imports_by_group_and_channel_with_fs_from_wf_increment(tmp_path):
    source, columns = write_tdms(tmp_path / "run.tdms")
    raw = tmp_path / "raw"
    capture, _ = imports(
        import_args(
            source,
            raw,
            "U=Untitled/Dev1/ai0:V",
            "x_disp=/'Untitled'/'x disp':um",
            extra=["--gain", "U=20", "--scale", "x_disp=10"],
        )
    )
    data, attrs, step, cap = read(capture, "U", "x_disp")
    assert cap.fs == FS and cap.n == N and attrs["scale_U"] == 20.0
    assert np.abs(data["U"] - 20 * columns[1]).max() <= step["U"]
    assert np.abs(data["x_disp"] - 10e-6 * columns[5]).max() <= step["x_disp"]
    assert load_dataset(raw, "lab")["daq"]["fs"] == FS
    # by position counted from 1, --fs agreeing with wf_increment
    capture, _ = imports(
        import_args(source, raw, "U=1:V", dataset="pos", extra=["--fs", "200", "--gain", "U=20"])
    )
    assert np.abs(read(capture, "U")[0]["U"] - 20 * columns[1]).max() <= step["U"]


def test_a_tdms_time_channel_must_agree_with_wf_increment(tmp_path):
    t = np.arange(N) / FS
    u = 100 * np.sin(2 * np.pi * t)
    source = tmp_path / "timed.tdms"
    props = {"wf_increment": 1 / FS}
    with TdmsWriter(source) as writer:
        writer.write_segment(
            [ChannelObject("g", "t", 3.0 + t, properties=props), ChannelObject("g", "U", u)]
        )
    capture, _ = imports(
        import_args(source, tmp_path / "raw", "U=g/U:V", extra=["--time", "g/t:s"])
    )
    data, attrs, step, cap = read(capture, "U")
    assert cap.fs == FS and np.abs(data["U"] - u).max() <= step["U"]
    assert "started at 3 s" in attrs["import_note"]
    # a time channel at 1 kHz, its wf_increment at 200 Hz: one clock, refused
    with TdmsWriter(source) as writer:
        writer.write_segment(
            [ChannelObject("g", "t", t / 5, properties=props), ChannelObject("g", "U", u, props)]
        )
    refused(
        import_args(source, tmp_path / "raw", "U=g/U:V", experiment="b", extra=["--time", "g/t:s"]),
        "the time column gives fs = 1000 Hz, wf_increment of channel 'g/U' (0.005 s) gives fs = "
        "200 Hz",
    )


@pytest.mark.parametrize(
    "channels,extra,fragments",
    [
        (["U=Untitled/Dev1/ai0:V"], ["--fs", "1000"], ["--fs says 1000 Hz", "gives fs = 200 Hz"]),
        (
            ["U=aux in:V"],
            [],
            [
                "channel 'aux in' for U is in the groups 'Untitled', 'Other group'",
                "type 'U=Untitled/aux in:V'",
            ],
        ),
        (
            ["U=Untitled/nothing:V"],
            [],
            ["no channel 'Untitled/nothing' for U", "1 'Untitled/Dev1/ai0'"],
        ),
        (
            ["U=9:V"],
            [],
            ["channel 9 for U does not exist (the file has 5 channels, counted from 1"],
        ),
        (
            ["U=Other group/aux in:V"],
            [],
            [
                "channel 'Other group/aux in' (U) holds one value (0)",
                "the channels that vary are 1 'Untitled/Dev1/ai0', 2 'Untitled/aux in', "
                "3 'Untitled/x disp'",
            ],
        ),
        (["U=Untitled/flag:V"], [], ["channel 'Untitled/flag' (U) is logical"]),
    ],
)
def test_a_tdms_channel_that_is_not_what_the_arguments_say_is_one_line(
    tmp_path, channels, extra, fragments
):
    flag = ChannelObject("Untitled", "flag", np.arange(N // 2) % 2 == 0)
    source, _ = write_tdms(tmp_path / "run.tdms", extra=[flag])
    refused(import_args(source, tmp_path / "raw", *channels, extra=extra), *fragments)


def test_a_tdms_file_without_wf_increment_needs_fs_or_time(tmp_path):
    source, columns = write_tdms(tmp_path / "run.tdms", increment=None)
    refused(
        import_args(source, tmp_path / "raw", "U=1:V"),
        "give the time column (--time) or the sampling rate (--fs): its channels declare no "
        "wf_increment",
    )
    capture, _ = imports(import_args(source, tmp_path / "raw", "U=1:V", extra=["--fs", "500"]))
    assert read(capture, "U")[3].fs == 500.0
    complex_ = tmp_path / "c.tdms"
    with TdmsWriter(complex_) as writer:
        writer.write_segment([ChannelObject("g", "z", np.arange(10) * (1 + 1j))])
    refused(
        import_args(complex_, tmp_path / "raw", "U=g/z:V", experiment="z", extra=["--fs", "5"]),
        "channel 'g/z' (U) is complex",
    )
    broken = tmp_path / "broken.tdms"
    broken.write_text("t,U\n0,1\n")
    refused(
        import_args(broken, tmp_path / "raw", "U=1:V", experiment="b", extra=["--fs", "5"]),
        "not a TDMS file",
    )
    broken.write_bytes(b"TDSm" + bytes(range(200)))
    refused(
        import_args(broken, tmp_path / "raw", "U=1:V", experiment="b", extra=["--fs", "5"]),
        "the TDMS file has no channels",
    )


# -- MATLAB v7.3 (HDF5) ----------------------------------------------------------------------------


def _matlab(obj, cls="double"):
    obj.attrs["MATLAB_class"] = np.bytes_(cls)
    return obj


def write_v73(path, n=N):
    """A file laid out as MATLAB's save -v7.3 lays it out: a 512-byte user block with MATLAB's
    header text, arrays stored transposed (MATLAB's n×2 a dataset of shape (2, n)), a struct a
    group of its fields, each with its MATLAB_class."""
    columns = daq_columns(n)
    with h5py.File(path, "w", userblock_size=512) as f:
        _matlab(f.create_dataset("data", data=np.vstack([columns[1], columns[5]])))
        rec = _matlab(f.create_group("rec"), "struct")
        _matlab(rec.create_dataset("Y", data=columns[2][None, :]))  # an n×1 column vector
        _matlab(rec.create_dataset("row", data=columns[2][:, None]))  # a 1×n row vector
        _matlab(f.create_dataset("idle", data=np.vstack([columns[3], columns[1]])))
        z = np.zeros((1, n), dtype=[("real", "<f8"), ("imag", "<f8")])
        _matlab(f.create_dataset("z", data=z))
        _matlab(f.create_dataset("flag", data=np.ones((1, n), dtype=np.uint8)), "logical")
        _matlab(f.create_dataset("name", data=np.ones((1, 5), dtype=np.uint16)), "char")
        refs = f.create_group("#refs#")
        target = refs.create_dataset("a", data=np.ones((1, n)))
        cell = f.create_dataset("cell", (1, 1), dtype=h5py.ref_dtype)
        cell[0, 0] = target.ref
        _matlab(cell, "cell")
    with open(path, "r+b") as raw:
        raw.write(
            b"MATLAB 7.3 MAT-file, Platform: GLNXA64, Created on: Mon Jan  1 00:00:00 2024 "
            b"HDF5 schema 1.00 .".ljust(116)
            + bytes(12)
        )
    return path, columns


def test_a_matlab_v73_file_imports_columns_counted_from_1(tmp_path):
    source, columns = write_v73(tmp_path / "run.mat")
    raw = tmp_path / "raw"
    capture, _ = imports(
        import_args(
            source,
            raw,
            "U=data[1]:V",
            "x_disp=data[2]:um",
            "Ur=rec.Y:V",
            extra=["--fs", "200", "--gain", "U=20", "--scale", "x_disp=10"],
        )
    )
    data, attrs, step, cap = read(capture, "U", "x_disp", "Ur")
    assert cap.fs == FS and cap.n == N and attrs["scale_kind_x_disp"] == "sensitivity"
    assert np.abs(data["U"] - 20 * columns[1]).max() <= step["U"]
    assert np.abs(data["x_disp"] - 10e-6 * columns[5]).max() <= step["x_disp"]
    assert np.abs(data["Ur"] - columns[2]).max() <= step["Ur"]
    capture, _ = imports(
        import_args(source, raw, "Ur=rec.row:V", dataset="row", extra=["--fs", "200"])
    )
    assert np.abs(read(capture, "Ur")[0]["Ur"] - columns[2]).max() <= step["Ur"]


@pytest.mark.parametrize(
    "channel,fragments",
    [
        (
            "U=data[0]:V",
            ["MATLAB counts from 1: data[1] is MATLAB's data(:,1)", "type 'U=data[1]:V'"],
        ),
        ("U=data[3]:V", ["data[3] does not exist (data is 4000×2; counted from 1)"]),
        ("U=data:V", ["has size 4000×2: name one column, e.g. data[1]"]),
        (
            "U=idle[1]:V",
            [
                "variable 'idle[1]' (U) holds one value (0)",
                "the columns of idle that vary are idle[2] (counted from 1)",
            ],
        ),
        ("U=z:V", ["variable z is complex"]),
        ("U=flag:V", ["variable flag is logical"]),
        ("U=name:V", ["'name' is not numeric"]),
        ("U=cell:V", ["'cell' is a cell array", "save(..., '-v7')"]),
        ("U=rec:V", ["'rec' is a struct: name one of its fields (Y, row)"]),
        ("U=rec[1].Y:V", ["struct arrays are not read"]),
        ("U=nothing:V", ["no variable 'nothing'"]),
        ("U=3:V", ["a .mat file names its variables", "type 'U=data[3]:V'"]),
    ],
)
def test_a_matlab_v73_variable_that_is_not_a_series_is_one_line(tmp_path, channel, fragments):
    source, _ = write_v73(tmp_path / "run.mat")
    refused(import_args(source, tmp_path / "raw", channel, extra=["--fs", "200"]), *fragments)


def test_a_v7_mat_file_counts_from_1_too(tmp_path):
    columns = daq_columns()
    runs = np.zeros((2,), dtype=[("Data", object)])  # a struct array rec.Y(1), rec.Y(2)
    runs[0]["Data"], runs[1]["Data"] = columns[2], columns[5]
    savemat(
        tmp_path / "v7.mat",
        {"data": np.column_stack([columns[1], columns[5]]), "rec": {"Y": runs}},
    )
    capture, _ = imports(
        import_args(
            tmp_path / "v7.mat",
            tmp_path / "raw",
            "U=data[1]:V",
            "x_disp=rec.Y[2].Data:um",
            extra=["--fs", "200"],
        )
    )
    data, _, step, _ = read(capture, "U", "x_disp")
    assert np.abs(data["U"] - columns[1]).max() <= step["U"]
    assert np.abs(data["x_disp"] - 1e-6 * columns[5]).max() <= step["x_disp"]
    refused(
        import_args(
            tmp_path / "v7.mat",
            tmp_path / "raw",
            "U=rec.Y[3].Data:V",
            experiment="e",
            extra=["--fs", "200"],
        ),
        "'rec.Y[3].Data': Y[3] does not exist (Y has 2 elements; counted from 1)",
    )
    refused(
        import_args(
            tmp_path / "v7.mat",
            tmp_path / "raw",
            "U=data[0]:V",
            experiment="e",
            extra=["--fs", "200"],
        ),
        "MATLAB counts from 1",
        "type 'U=data[1]:V'",
    )


def test_a_request_built_in_python_takes_positions_from_1(tmp_path):
    source = write_table(tmp_path / "run3.txt", daq_columns())
    request = Request(
        source,
        "lab",
        "run",
        (parse_column("U=2:V"),),
        fs=FS,
        header=False,
        raw_dir=tmp_path / "raw",
        scales={"U": (20.0, "gain")},
    )
    capture, manifest = run_import(request)
    assert yaml.safe_load(manifest.read_text())["sensors"]["U"]["scale"] == 20.0
