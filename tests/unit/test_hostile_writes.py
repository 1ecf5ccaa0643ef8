"""An analysis rule's writes on a full disk, and a job whose input another run removed: one line
naming the file (also in the rule's log), and nothing half-written left behind."""

import errno
import logging
import os
import subprocess
import sys
from pathlib import Path

import matplotlib
import netCDF4
import numpy as np
import pandas as pd
import pytest

from selfsense.io import capture as capture_module
from selfsense.io.capture import CaptureWriteError, SeriesWriter
from selfsense.io.provenance import (
    OutputWriteError,
    atomic_path,
    one_line_reason,
    save_figure,
    write_json,
    write_table,
)

from ..helpers import ROOT, leftovers, one_line, script, synthetic

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402 (after the backend)

FULL = "no space left on device"


def enospc(*args, **kwargs):
    raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))


def files(folder):
    return sorted(p.name for p in folder.rglob("*") if p.is_file())


@pytest.fixture
def inputs(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "raw").mkdir()
    (tmp_path / "raw" / "c.nc").write_bytes(b"a capture")
    return ["raw/c.nc"]


def test_a_table_on_a_full_disk_is_one_line_naming_it_and_leaves_nothing(inputs, monkeypatch):
    real = pd.DataFrame.to_csv

    def half_then_full(self, path, *args, **kwargs):
        real(self.head(1), path, *args, **kwargs)  # a part of the table reached the disk
        enospc()

    monkeypatch.setattr(pd.DataFrame, "to_csv", half_then_full)
    table = "results/t.csv"
    with pytest.raises(OutputWriteError) as e:
        write_table(pd.DataFrame({"x [m]": [1.0, 2.0]}), table, inputs=inputs)
    one_line(str(e.value), table, f"cannot write the output: {FULL}")
    assert one_line_reason(e.value) == str(e.value)  # the rule's log holds the same line
    assert files(Path("results")) == []


def test_a_previous_table_stays_whole_when_the_disk_is_full(inputs, monkeypatch):
    table = "results/t.csv"
    write_table(pd.DataFrame({"x [m]": [1.0]}), table, inputs=inputs)
    before = {n: open(f"results/{n}", "rb").read() for n in ("t.csv", "t.csv.json")}
    monkeypatch.setattr(pd.DataFrame, "to_csv", enospc)
    with pytest.raises(OutputWriteError):
        write_table(pd.DataFrame({"x [m]": [2.0]}), table, inputs=inputs)
    assert {n: open(f"results/{n}", "rb").read() for n in before} == before
    assert leftovers("results") == []


def test_a_sidecar_that_cannot_be_written_takes_its_table_with_it(inputs, monkeypatch):
    """A table without its sidecar would pass for one made before provenance (and the audit
    could not follow it)."""
    real = Path.write_text

    def full_for_json(self, text, *args, **kwargs):
        if ".json" in self.name:
            enospc()
        return real(self, text, *args, **kwargs)

    monkeypatch.setattr(Path, "write_text", full_for_json)
    table = "results/t.csv"
    with pytest.raises(OutputWriteError) as e:
        write_table(pd.DataFrame({"x [m]": [1.0]}), table, inputs=inputs)
    one_line(str(e.value), f"{table}.json", f"cannot write the output: {FULL}")
    assert files(Path("results")) == []


def test_a_figure_on_a_full_disk_is_one_line_naming_it(inputs, monkeypatch):
    fig = plt.figure()
    monkeypatch.setattr(fig, "savefig", enospc)
    with pytest.raises(OutputWriteError) as e:
        save_figure(fig, "figures/f.png", inputs=inputs)
    plt.close(fig)
    one_line(str(e.value), "figures/f.png", FULL)
    assert files(Path("figures")) == []


def test_a_report_on_a_read_only_file_system_is_named(inputs, monkeypatch):
    def read_only(*args):
        raise OSError(errno.EROFS, os.strerror(errno.EROFS))

    monkeypatch.setattr(os, "replace", read_only)
    with pytest.raises(OutputWriteError) as e:
        write_json({"n": 1}, "results/r.json")
    one_line(str(e.value), "results/r.json", "folder is read-only (read-only file system)")


def test_an_input_refused_while_writing_is_not_taken_for_the_outputs_folder(inputs):
    """Only the output's own errors become OutputWriteError: an input refused by permissions
    inside the writing block stays the input's error, naming the input."""
    with pytest.raises(PermissionError) as e:
        with atomic_path("results/r.csv"):
            raise PermissionError(errno.EACCES, "Permission denied", "raw/c.nc")
    assert not isinstance(e.value, OutputWriteError) and e.value.filename == "raw/c.nc"
    assert files(Path("results")) == []


class FullDiskDataset(netCDF4.Dataset):
    """netCDF-C's answer to a full disk: the cached chunks of a file being written (a writer's
    temporary, <name>.<host>.<random>.part) fail on close with "HDF error"; reads succeed."""

    def close(self):
        writing = self.filepath().endswith(".part")
        super().close()
        if writing:
            raise RuntimeError("NetCDF: HDF error")


def full_disk(monkeypatch):
    """The file system refuses every allocation with ENOSPC (a real full disk needs a mount)."""
    monkeypatch.setattr(os, "posix_fallocate", lambda fd, offset, size: enospc())
    monkeypatch.setattr(capture_module.netCDF4, "Dataset", FullDiskDataset)


def test_a_series_on_a_full_disk_is_one_line_naming_it_and_leaves_nothing(tmp_path, monkeypatch):
    full_disk(monkeypatch)
    series = tmp_path / "ripple" / "s.nc"
    with pytest.raises(CaptureWriteError) as e:
        with SeriesWriter(series, {"C_e": "F"}, inputs=[]) as w:
            w.write({"C_e": np.zeros(100)})
    one_line(str(e.value), series, f"cannot write the series: {FULL}")
    assert files(tmp_path / "ripple") == []


def test_the_ripple_rule_on_a_full_disk_names_its_series_in_its_log(tmp_path, monkeypatch):
    capture = synthetic(tmp_path / "ch3_sine_10hz.nc")
    full_disk(monkeypatch)
    monkeypatch.setattr(sys, "excepthook", sys.excepthook)  # the script sets its own: undone
    series, log = tmp_path / "ripple" / "ch3_sine_10hz.nc", tmp_path / "rule.log"
    with pytest.raises(CaptureWriteError) as e:
        script("extract_ripple").main(str(capture), str(series), 4, log=str(log))
    one_line(str(e.value), series, f"cannot write the series: {FULL}")
    sys.excepthook(type(e.value), e.value, None)  # what the script's process does with it
    logging.getLogger("selfsense").handlers.clear()
    assert log.read_text().strip().splitlines()[-1] == f"ERROR {e.value}"
    assert files(tmp_path / "ripple") == []


# -- an input removed while the job ran -----------------------------------------------------------

REMOVED_UNDER_THE_JOB = """
import os, sys
from types import SimpleNamespace
sys.path.insert(0, sys.argv[4])
from tests.helpers import script
series, table, phases, log = sys.argv[1], sys.argv[2], sys.argv[3], sys.argv[5]
# the rule's inputs as Snakemake gives them to the script it runs
snakemake = SimpleNamespace(input=[series])
os.unlink(series)  # another run removes it after Snakemake started the job
script("ch3_hysteresis").main(series, table, phases, 0.1, 10.0, [series], log=log)
"""


def test_an_input_another_run_removed_is_one_line_naming_it_not_a_traceback(tmp_path):
    capture = synthetic(tmp_path / "ch3_sine_10hz.nc")
    series = tmp_path / "ripple.nc"
    script("extract_ripple").main(str(capture), str(series), 4)
    table, phases, log = tmp_path / "h.csv", tmp_path / "p.csv", tmp_path / "rule.log"
    args = [series, table, phases, ROOT, log]
    run = subprocess.run(
        [sys.executable, "-c", REMOVED_UNDER_THE_JOB, *map(str, args)],
        capture_output=True,
        text=True,
        timeout=300,
        env=os.environ | {"PYTHONPATH": str(ROOT / "src")},
    )
    assert run.returncode == 1
    assert "Traceback" not in run.stderr, run.stderr
    (line,) = run.stderr.strip().splitlines()
    one_line(line, series, "missing input: it was there when this job started and was removed")
    assert f"(the job stopped on: {series}: no such series)" in line
    assert log.read_text().strip() == f"ERROR {line}"
    assert not table.exists() and not phases.exists()


def test_a_failure_with_every_input_there_keeps_its_traceback(tmp_path):
    """Only a missing input drops the traceback: any other failure may be a bug."""
    run = subprocess.run(
        [
            sys.executable,
            "-c",
            "import sys; from types import SimpleNamespace\n"
            "from selfsense.io.provenance import script_logging\n"
            f"snakemake = SimpleNamespace(input=[{str(ROOT / 'config.yaml')!r}])\n"
            f"script_logging({str(tmp_path / 'rule.log')!r})\n"
            "raise ValueError('x')",
        ],
        capture_output=True,
        text=True,
        timeout=120,
        env=os.environ | {"PYTHONPATH": str(ROOT / "src")},
    )
    assert run.returncode == 1 and "Traceback" in run.stderr
    assert (tmp_path / "rule.log").read_text().strip() == "ERROR ValueError: x"
