"""`selfsense import` against hostile recordings and arguments (the Import rows of the fault
matrix in docs/reliability.md).

Every fault ends in one line naming the file or the argument, exit 1, and nothing behind: no
capture, no temporary, no manifest change, no new folder; what can be imported honestly is
(overload sentinels stored as missing and counted, data rows ending in the separator, a time
axis jittered by less than a quarter sample). Two imports at once into one dataset run one after
the other. A property test feeds arbitrary numeric columns, separators and lengths.
"""

import contextlib
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import pytest
import yaml
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st
from scipy.io import savemat

from selfsense.io.capture import CHANNEL_UNITS, channel_spec, open_capture
from selfsense.io.dataset_lock import dataset_lock
from selfsense.io.importer import (
    MAX_NAME,
    MIN_CODES,
    PLAUSIBLE,
    Request,
    derived_range,
    run_import,
)
from selfsense.io.manifest import load_dataset
from selfsense.io.sources import ImportProblem, parse_column

from ..helpers import (
    LAB_FS,
    ellipse,
    import_args,
    imports,
    leftovers,
    refused,
    run_import_command,
    tree,
    write_csv,
)

SELFSENSE = Path(sys.executable).with_name("selfsense")


def read(capture, *channels):
    with open_capture(capture) as cap:
        return cap.read(list(channels)), cap.attrs, {c: cap.resolution(c) for c in channels}


def write_rows(path, header, rows, sep=","):
    lines = ([sep.join(header)] if header is not None else []) + [
        sep.join(map(str, r)) for r in rows
    ]
    path.write_text("\n".join(lines) + "\n")
    return path


# -- fs, names -------------------------------------------------------------------------------------


@pytest.mark.parametrize("fs", ["nan", "0", "-5000", "inf"])
def test_a_bad_fs_leaves_nothing_behind_and_the_corrected_retry_works(tmp_path, fs):
    source = write_csv(tmp_path / "sine.csv")
    raw = tmp_path / "raw"
    args = import_args(source, raw, "U=U [V]:V", extra=["--fs", fs])
    refused(args, "the sampling rate must be a finite number > 0 Hz", starts="--fs ")
    assert not raw.exists()  # not even the dataset's folder
    args[args.index(fs)] = str(LAB_FS)
    capture, _ = imports(args)
    assert capture.exists() and load_dataset(raw, "lab")["daq"]["fs"] == LAB_FS


@pytest.mark.parametrize("option", ["--experiment", "--dataset"])
def test_a_name_too_long_for_a_file_is_refused_naming_the_option(tmp_path, option):
    source = write_csv(tmp_path / "sine.csv")
    args = import_args(source, tmp_path / "raw", "U=U [V]:V", extra=["--fs", str(LAB_FS)])
    args[args.index(option) + 1] = "e" * 300
    refused(args, "a name of 300 characters: at most 100", starts=option)
    assert not (tmp_path / "raw").exists()
    args[args.index(option) + 1] = "e" * MAX_NAME  # the longest allowed works
    capture, _ = imports(args)
    assert capture.exists()


def test_a_file_system_error_is_one_line_naming_the_path(tmp_path):
    source = write_csv(tmp_path / "sine.csv")
    raw = tmp_path / ("r" * 300)  # ENAMETOOLONG from the file system itself
    refused(
        import_args(source, raw, "U=U [V]:V", extra=["--fs", "5000"]),
        "file name too long",
        starts=raw,
    )


# -- the file's layout and its cells ---------------------------------------------------------------


def test_data_rows_ending_in_the_separator_keep_their_columns(tmp_path):
    t, u, x = ellipse(periods=1)
    rows = [
        (f"{a!r}", f"{b!r}", f"{c * 1e6!r}", "")
        for a, b, c in zip(t.tolist(), u.tolist(), x.tolist())
    ]
    source = write_rows(tmp_path / "trailing.csv", ["t", "U", "x"], rows)  # data: one field more
    for extra, experiment in ((["--fs", str(LAB_FS)], "by_fs"), (["--time", "t:s"], "by_time")):
        capture, _ = imports(
            import_args(
                source,
                tmp_path / "raw",
                "U=U:V",
                "x_laser=x:um",
                experiment=experiment,
                extra=extra,
            )
        )
        data, _, step = read(capture, "U", "x_laser")
        assert (
            np.abs(data["U"] - u).max() <= step["U"]
            and np.abs(data["x_laser"] - x).max() <= (step["x_laser"])
        )
    # the header ending in the separator, the data rows not: the same
    source.write_text(
        "t,U,x,\n"
        + "".join(
            f"{a!r},{b!r},{c * 1e6!r}\n" for a, b, c in zip(t.tolist(), u.tolist(), x.tolist())
        )
    )
    capture, _ = imports(
        import_args(source, tmp_path / "raw", "U=U:V", experiment="header", extra=["--time", "t:s"])
    )
    assert np.abs(read(capture, "U")[0]["U"] - u).max() <= step["U"]


@pytest.mark.parametrize(
    "text,channels,fragments",
    [
        pytest.param(
            "t,U,x\n0,1,2,5\n1,2,3,6\n",
            ["U=U:V"],
            ["data row 1 has 4 fields, the header has 3", "the header may lack a column"],
            id="data rows with a field more",
        ),
        pytest.param(
            "t,U,x\n0,1,2\n1,2\n",
            ["U=U:V"],
            ["data row 2 has 2 fields, the header has 3"],
            id="a row with a field less",
        ),
        pytest.param(
            "t,U,x\n" + "".join(f"{k},1,2\n" for k in range(20)) + "20,1\n",
            ["U=U:V"],
            ["the last data row has 2 fields"],
            id="a truncated last row",
        ),
        pytest.param(
            "t,U,x\n0,1,2\n", ["U=V:V"], ["no column 'V' for U (columns: t, U, x)"], id="name"
        ),
        pytest.param(
            "t,U,x\n0,1,2\n",
            ["U=4:V"],
            ["column 4 for U does not exist (the file has 3 columns, counted from 1)"],
            id="index",
        ),
        pytest.param(
            "t|U|x\n0|1|2\n",
            ["U=U:V"],
            ["no comma, semicolon or tab splits its rows alike: give --sep, e.g. --sep '|'"],
            id="separator",
        ),
        pytest.param(
            "t,U,U\n0,1,2\n", ["U=U:V"], ["column 'U' for U is in the header 2 times"], id="twice"
        ),
        pytest.param(
            "t,U,x\n0,1,2\n1,abc,3\n",
            ["U=U:V"],
            ["column 'U' (U) holds 'abc' at data row 2, not a number"],
            id="text",
        ),
        pytest.param(
            "t,U,x\n0,True,2\n1,False,3\n", ["U=U:V"], ["holds 'True' at data row 1"], id="boolean"
        ),
        pytest.param(
            "t,U,x\n0,1+2j,2\n",
            ["U=U:V"],
            ["holds '1+2j' at data row 1, not a number"],
            id="complex",
        ),
        pytest.param(
            "t,U,x\n0,inf,2\n1,-inf,3\n2,inf,4\n",
            ["U=U:V"],
            ["column 'U' (U) holds no value to import", "3 are overloads"],
            id="an inf column",
        ),
        pytest.param(
            "t,U,x\n0,,2\n1,,3\n2,,4\n",
            ["U=U:V"],
            ["column 'U' (U) holds no value to import", "3 are empty"],
            id="an all-empty column",
        ),
        pytest.param(
            "t,U,x\n0,1,2\n1,2,3\n", ["U=U:V", "U=x:V"], ["name each channel once"], id="U twice"
        ),
        pytest.param("t,U,x\n", ["U=U:V"], ["no data rows"], id="header only"),
        pytest.param("", ["U=U:V"], ["empty file"], id="empty file"),
    ],
)
def test_a_file_that_is_not_what_the_arguments_say_is_one_line(tmp_path, text, channels, fragments):
    source = tmp_path / "bad.csv"
    source.write_text(text)
    refused(import_args(source, tmp_path / "raw", *channels, extra=["--fs", "1000"]), *fragments)
    assert not (tmp_path / "raw").exists()


def test_a_bad_separator_is_one_line_naming_the_option(tmp_path):
    source = write_rows(tmp_path / "a.csv", ["U"], [[1], [2]])
    for sep in ("ab", ".", "-", "e"):
        refused(
            import_args(source, tmp_path / "raw", "U=U:V", extra=["--fs", "10", "--sep", sep]),
            "one character that cannot be part of a number",
            starts="--sep",
        )


def test_a_tab_separated_file_with_empty_cells_keeps_its_columns(tmp_path):
    source = tmp_path / "a.tsv"
    source.write_text("U\tx\n1\t\n\t2\n3\t4\n")
    capture, _ = imports(
        import_args(source, tmp_path / "raw", "U=U:V", "x_laser=x:um", extra=["--fs", "10"])
    )
    data, _, step = read(capture, "U", "x_laser")
    np.testing.assert_allclose(data["U"], [1, np.nan, 3], atol=step["U"])
    np.testing.assert_allclose(data["x_laser"], [np.nan, 2e-6, 4e-6], atol=step["x_laser"])


# -- overload sentinels ----------------------------------------------------------------------------


@pytest.mark.parametrize("sentinel", ["9.9E+37", "1e308", "inf", "-inf"])
def test_an_overload_sentinel_is_stored_as_missing_and_counted_before_the_range(
    tmp_path, sentinel, caplog
):
    t, u, x = ellipse()
    lines = [f"{a!r},{b!r},{c * 1e6!r}" for a, b, c in zip(t.tolist(), u.tolist(), x.tolist())]
    lines[100] = f"{float(t[100])!r},{float(u[100])!r},{sentinel}"
    source = tmp_path / "overload.csv"
    source.write_text("t,U,x\n" + "\n".join(lines) + "\n")
    capture, err = imports(
        import_args(source, tmp_path / "raw", "U=U:V", "x_laser=x:um", extra=["--time", "t:s"])
    )
    data, attrs, step = read(capture, "x_laser")
    assert np.isnan(data["x_laser"][100]) and np.isnan(data["x_laser"]).sum() == 1
    clean = np.delete(x, 100)
    assert np.abs(np.delete(data["x_laser"], 100) - clean).max() <= step["x_laser"]
    note = attrs["import_note"]
    assert "x_laser: 1 overload value(s)" in note and "at data row 101" in note
    said = [r.getMessage() for r in caplog.records]  # a warning naming the file
    assert any(m.startswith(f"{source}: x_laser: 1 overload value(s)") for m in said)
    # the range is the clean data's: the sentinel never reached it
    lo, hi = load_dataset(tmp_path / "raw", "lab")["daq"]["ranges"]["x_laser"]
    assert lo < clean.min() and hi > clean.max() and hi - lo < 1.5 * np.ptp(clean)


def test_a_channel_overloaded_beyond_1_percent_is_refused(tmp_path):
    rows = [(k, "9.9E+37" if k % 50 == 0 else k) for k in range(1000)]  # 2 %
    source = write_rows(tmp_path / "overload.csv", ["t", "x"], rows)
    refused(
        import_args(source, tmp_path / "raw", "x_laser=x:um", extra=["--fs", "1000"]),
        "column 'x' (x_laser) is overloaded in 2 % of its 1000 samples",
        "first 9.9e+37 at data row 1",
    )


# -- MATLAB files ----------------------------------------------------------------------------------


def test_a_complex_mat_variable_is_refused(tmp_path):
    t, u, x = ellipse(periods=1)
    savemat(tmp_path / "c.mat", {"U": u, "x": x * 1e6 * (1 + 0.5j)})
    refused(
        import_args(
            tmp_path / "c.mat", tmp_path / "raw", "U=U:V", "x_laser=x:um", extra=["--fs", "5000"]
        ),
        "variable x is complex",
    )
    savemat(tmp_path / "b.mat", {"U": u, "x": "a text"})
    refused(
        import_args(
            tmp_path / "b.mat", tmp_path / "raw", "U=U:V", "x_laser=x:um", extra=["--fs", "5000"]
        ),
        "'x' is not numeric",
    )
    savemat(tmp_path / "l.mat", {"U": u, "x": x[:-5]})
    refused(
        import_args(
            tmp_path / "l.mat", tmp_path / "raw", "U=U:V", "x_laser=x:um", extra=["--fs", "5000"]
        ),
        "the variables differ in length",
    )
    savemat(tmp_path / "inf.mat", {"U": u, "x": np.full_like(x, np.inf)})
    refused(
        import_args(
            tmp_path / "inf.mat", tmp_path / "raw", "U=U:V", "x_laser=x:um", extra=["--fs", "5000"]
        ),
        "variable 'x' (x_laser) holds no value to import",
    )
    assert not (tmp_path / "raw").exists()


# -- the time axis ---------------------------------------------------------------------------------


def jittered(path, jitter, seed=3):
    """The lab's ellipse with its time column jittered uniformly by ±jitter samples, the end
    points at the extremes (where an end-point fs is most wrong)."""
    t, u, x = ellipse()
    shift = np.random.default_rng(seed).uniform(-jitter, jitter, len(t))
    shift[0], shift[-1] = jitter, -jitter
    t = 7.0 + t + shift / LAB_FS
    path.write_text("t,U\n" + "".join(f"{a!r},{b!r}\n" for a, b in zip(t.tolist(), u.tolist())))
    return path


def test_a_time_axis_jittered_within_a_quarter_sample_is_accepted_with_fs_from_the_fit(tmp_path):
    source = jittered(tmp_path / "jitter.csv", 0.2)
    capture, _ = imports(import_args(source, tmp_path / "raw", "U=U:V", extra=["--time", "t:s"]))
    fs = load_dataset(tmp_path / "raw", "lab")["daq"]["fs"]
    assert abs(fs / LAB_FS - 1) < 1e-6  # end points alone: 0.4 samples over 15 000, 2.7e-5
    with open_capture(capture) as cap:
        assert cap.fs == fs and "started at 7.00004 s" in cap.attrs["import_note"]


def test_a_time_axis_off_by_more_than_a_quarter_sample_is_refused(tmp_path):
    source = jittered(tmp_path / "jitter.csv", 0.2)
    lines = source.read_text().splitlines()
    t, u = (float(v) for v in lines[5001].split(","))
    lines[5001] = f"{t + 0.3 / LAB_FS!r},{u!r}"  # sample 5000 another 0.3 samples late
    source.write_text("\n".join(lines) + "\n")
    refused(
        import_args(source, tmp_path / "raw", "U=U:V", extra=["--time", "t:s"]),
        "the time column is not sampled at a fixed rate: sample 5000",
        "on the least-squares line",
    )
    assert not (tmp_path / "raw").exists()  # the second pass had begun: its temporary is gone


def test_a_time_column_with_a_hole_is_refused(tmp_path):
    source = write_rows(tmp_path / "hole.csv", ["t", "U"], [(0, 1), ("", 2), (0.002, 3)])
    refused(
        import_args(source, tmp_path / "raw", "U=U:V", extra=["--time", "t:s"]),
        "the time column 't' is empty at data row 2",
    )


# -- atomicity and concurrency ---------------------------------------------------------------------


def test_a_manifest_that_cannot_be_written_takes_the_capture_with_it(tmp_path, monkeypatch):
    from selfsense.io import importer

    @contextlib.contextmanager
    def failing(path):
        raise OSError(28, "No space left on device", str(path))
        yield

    monkeypatch.setattr(importer, "atomic_path", failing)
    source = write_csv(tmp_path / "sine.csv")
    refused(
        import_args(source, tmp_path / "raw", "U=U [V]:V", extra=["--fs", "5000"]),
        "No space left on device",
        starts=tmp_path / "raw" / "lab" / "dataset.yaml",
    )
    assert not (tmp_path / "raw").exists()


def test_an_import_waits_for_the_datasets_lock_and_gives_up_in_one_line(tmp_path):
    source = write_csv(tmp_path / "sine.csv")
    folder = tmp_path / "raw" / "lab"
    request = Request(
        source,
        "lab",
        "run",
        (parse_column("U=U [V]:V"),),
        fs=LAB_FS,
        raw_dir=tmp_path / "raw",
        lock_timeout=0.3,
    )
    with dataset_lock(folder):
        with pytest.raises(ImportProblem) as e:
            run_import(request)
    assert str(e.value).startswith(
        str(folder / ".import.lock")
    ) and "still runs after 0.3 s" in str(e.value)
    assert not folder.exists()  # the lock's folder made for it is gone with it
    run_import(request)
    assert sorted(p.name for p in folder.iterdir()) == ["dataset.yaml", "run.nc"]


def _at_once(commands, cwd):
    procs = [
        subprocess.Popen(c, cwd=cwd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        for c in commands
    ]
    return [(p.wait(timeout=300), *p.communicate()) for p in procs]


def test_two_imports_at_once_run_one_after_the_other_and_never_overwrite(tmp_path):
    t, u, x = ellipse(periods=10)  # 50 000 rows: each import reads for a while
    sources = []
    for k in range(2):
        path = tmp_path / f"run{k}.csv"
        path.write_text(
            "t,U,x\n"
            + "".join(
                f"{a!r},{b * (k + 1)!r},{c * 1e6!r}\n"
                for a, b, c in zip(t.tolist(), u.tolist(), x.tolist())
            )
        )
        sources.append(path)

    def command(source, dataset, experiment):
        return [
            str(SELFSENSE),
            *import_args(
                source,
                "raw",
                "U=U:V",
                dataset=dataset,
                experiment=experiment,
                extra=["--time", "t:s", "--range", "U=-400,400"],
            ),
        ]

    for trial in range(3):
        # two experiments into one new dataset: both in its manifest
        dataset = f"both{trial}"
        results = _at_once([command(sources[k], dataset, f"run{k}") for k in range(2)], tmp_path)
        assert [r[0] for r in results] == [0, 0], results
        manifest = load_dataset(tmp_path / "raw", dataset)
        assert sorted(manifest["experiments"]) == ["run0", "run1"]
        assert sorted(p.name for p in (tmp_path / "raw" / dataset).iterdir()) == [
            "dataset.yaml",
            "run0.nc",
            "run1.nc",
        ]
        # the same experiment twice: the second refused, the first's capture kept
        dataset = f"same{trial}"
        results = _at_once([command(sources[k], dataset, "run") for k in range(2)], tmp_path)
        assert sorted(r[0] for r in results) == [0, 1], results
        winner = [k for k, r in enumerate(results) if r[0] == 0][0]
        loser = results[1 - winner][2].strip().splitlines()[-1]
        assert (
            loser.startswith("selfsense import: raw/")
            and "exists: measured captures are never overwritten" in loser
        )
        data, _, step = read(tmp_path / "raw" / dataset / "run.nc", "U")
        assert np.abs(data["U"] - u * (winner + 1)).max() <= step["U"]
        assert load_dataset(tmp_path / "raw", dataset)["experiments"] == ["run"]
        assert leftovers(tmp_path / "raw") == []


# -- the property: a correct capture or one line ---------------------------------------------------

SEPARATORS = [",", ";", "\t", "|", " "]
SENTINELS = ["9.9E+37", "1e308", "inf", "-inf"]
#: magnitudes around the plausibility limits (a first import refuses |U| > 10 kV and a
#: displacement spanning more than 1 cm or less than 0.1 nm: x is written in µm)
FINITE = st.one_of(
    st.floats(-2e4, 2e4, allow_nan=False, allow_infinity=False),
    st.integers(-(2 * 10**4), 2 * 10**4),
)


@st.composite
def recordings(draw):
    n = draw(st.integers(1, 40))
    k = draw(st.integers(1, 3))  # data columns besides the row counter
    noisy = draw(st.booleans())
    cell = st.one_of(FINITE, FINITE, st.none(), st.sampled_from(SENTINELS)) if noisy else FINITE
    columns = [draw(st.lists(cell, min_size=n, max_size=n)) for _ in range(k)]
    return {
        "columns": columns,
        "sep": draw(st.sampled_from(SEPARATORS)),
        "header": draw(st.booleans()),
        "trailing": draw(st.booleans()),
        "time": draw(st.booleans()),
    }


def _plausible(channel, lo, hi):
    """Whether a first import takes a channel spanning [lo, hi] (contract unit): it varies,
    within PLAUSIBLE's limits, over at least MIN_CODES int16 codes of the range derived from it
    (a span far below the derived range's floor, 1e-160 V, would pack into one code)."""
    rule = PLAUSIBLE[CHANNEL_UNITS[channel][0]]
    if not (lo < hi and max(abs(lo), abs(hi)) <= rule.peak):
        return False
    codes = (hi - lo) / channel_spec(channel, *derived_range(lo, hi)).scale_factor
    return rule.span[0] <= hi - lo <= rule.span[1] and codes >= MIN_CODES


def _text(value):
    return "" if value is None else value if isinstance(value, str) else repr(value)


@settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(rec=recordings())
# a voltage spanning 2.7e-160 V: below the derived range's floor, one line saying so
@example(
    rec={
        "columns": [[0.0, 2.7337076360044518e-160]],
        "sep": ",",
        "header": False,
        "trailing": False,
        "time": False,
    }
)
def test_any_numeric_columns_give_a_correct_capture_or_one_line_naming_the_file(rec):
    columns, sep, n = rec["columns"], rec["sep"], len(rec["columns"][0])
    fs = 1000.0
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        source = tmp / "rec.txt"
        header = ["t", *(f"c{j}" for j in range(len(columns)))]
        lines = [sep.join(header)] if rec["header"] else []
        for i in range(n):  # the first column (the time, or a counter) is never empty
            cells = [repr(i / fs), *(_text(c[i]) for c in columns)]
            lines.append(sep.join(cells) + (sep if rec["trailing"] else ""))
        source.write_text("\n".join(lines) + "\n")
        wanted = {"U": (columns[0], "V", 1.0)}
        if len(columns) > 1:
            wanted["x_laser"] = (columns[1], "um", 1e-6)
        # a column by its header name, or by its position counted from 1
        where = (lambda j: header[j]) if rec["header"] else (lambda j: str(j + 1))
        args = import_args(
            source,
            tmp / "raw",
            *(f"{c}={where(j + 1)}:{unit}" for j, (c, (_, unit, _)) in enumerate(wanted.items())),
            extra=[
                "--sep",
                sep,
                *(["--time", f"{where(0)}:s"] if rec["time"] else ["--fs", str(fs)]),
                *([] if rec["header"] else ["--no-header"]),
            ],
        )
        expected, importable = {}, True
        for channel, (cells, _, factor) in wanted.items():
            values = np.array(
                [np.nan if c is None or isinstance(c, str) else float(c) for c in cells]
            )
            overloads = sum(isinstance(c, str) for c in cells)
            if np.isnan(values).all() or overloads > 0.01 * n:
                importable = False
            expected[channel] = values * factor
            valid = expected[channel][~np.isnan(values)]
            if valid.size and not _plausible(channel, valid.min(), valid.max()):
                importable = False  # one value throughout, or not what a piezo bench records
        if n < 2:  # a capture holds two samples at the least
            importable = False
        status, err = run_import_command(args)
        lines = [line for line in err.splitlines() if line.startswith("selfsense import: ")]
        if status:
            assert status == 1 and len(lines) == 1, err
            assert lines[0].startswith(f"selfsense import: {source}: "), lines[0]
            assert not importable, lines[0]
            assert not (tmp / "raw").exists() and tree(tmp) == {"rec.txt": source.read_bytes()}
            return
        assert importable and not lines, err
        folder = tmp / "raw" / "lab"
        assert sorted(p.name for p in folder.iterdir()) == ["dataset.yaml", "run.nc"]
        manifest = yaml.safe_load((folder / "dataset.yaml").read_text())
        assert manifest["experiments"] == ["run"] and abs(manifest["daq"]["fs"] / fs - 1) < 1e-6
        with open_capture(folder / "run.nc") as cap:
            assert cap.n == n
            for channel, values in expected.items():
                got = cap.read([channel])[channel]
                scale = cap.resolution(channel)
                lo, hi = manifest["daq"]["ranges"][channel]
                assert np.array_equal(np.isnan(got), np.isnan(values))
                ok = ~np.isnan(values)
                size = max(np.abs(values[ok]).max(), abs(lo), abs(hi))
                assert np.all(np.abs(got[ok] - values[ok]) <= 0.5 * scale + 8 * np.spacing(size))
