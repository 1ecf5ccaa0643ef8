"""Faults beyond the first fault matrix (docs/reliability.md) that need Snakemake: two runs at
once never damage a capture and a damaged one is found; a fault set with --config is blamed on it.
The rest of these faults, at the capture, manifest and rule-script level, are in
tests/unit/test_faults.py.
"""

import re
import subprocess

import pytest

from selfsense.io.capture import scan_capture

from ..helpers import (
    CH3,
    assert_same_capture,
    copy_repo,
    error_line,
    leftovers,
    run_snakemake,
    snakemake_command,
    write_config,
)

#: how a run at once with another stops when that one removed the capture it had just written
RACE = re.compile(r"No such file or directory: 'raw/pi_p885/\w+\.nc'|MissingOutputException")


@pytest.mark.slow
def test_two_runs_at_once_never_damage_a_capture_and_a_damaged_one_is_found(smoke_run, tmp_path):
    """Two Snakemake processes simulate the same captures at the same time (--nolock: what a
    removed lock directory or an --unlock while a run goes on amounts to). Every writer has its
    own temporary and verifies it before the rename, so every capture reads back whole and equal
    to a clean run's (a run may stop when the other removed a capture it had just written, never
    with a damaged one). A capture damaged afterwards is found by the next run (the jobs that read
    it rerun, the capture being newer than their outputs, and stop with one line) instead of
    "Nothing to be done"."""
    repo = copy_repo(tmp_path / "repo")
    config = write_config(repo, "pi", ["pi_p885"])
    captures = [f"raw/pi_p885/{e}.nc" for e in CH3]
    a = subprocess.Popen(
        snakemake_command("--nolock", *captures, config=config, cores=1),
        cwd=repo,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    b = subprocess.Popen(
        snakemake_command("--nolock", *reversed(captures), config=config, cores=1),
        cwd=repo,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    out_a, out_b = a.communicate(timeout=1200), b.communicate(timeout=1200)
    for proc, (out, _) in ((a, out_a), (b, out_b)):
        # Snakemake removes a job's outputs before it runs the job: the other run may remove a
        # capture this one has just written, and this one then stops for want of it
        assert proc.returncode == 0 or RACE.search(out), out[-3000:]
    # what a stopped run left undone, made by a run on its own
    assert run_snakemake(repo, *captures, config=config).returncode == 0
    for c in captures:
        scan_capture(repo / c)  # every sample, every checksum
        assert_same_capture(repo / c, smoke_run / c)
    assert leftovers(repo / "raw") == []

    series = "results/pi_p885/ripple/ch3_sine_1hz.nc"  # extract_ripple's: it streams the capture
    assert run_snakemake(repo, series, config=config).returncode == 0
    damaged = repo / "raw" / "pi_p885" / "ch3_sine_1hz.nc"
    data = bytearray(damaged.read_bytes())
    # a hole over the middle half: the writer interleaves the variables' chunks, so it hits every
    # one
    data[len(data) // 4 : 3 * len(data) // 4] = bytes(3 * len(data) // 4 - len(data) // 4)
    damaged.write_bytes(bytes(data))
    run = run_snakemake(repo, series, config=config)
    assert run.returncode != 0 and "Nothing to be done" not in run.stdout + run.stderr
    line = error_line(run, "CaptureError: raw/pi_p885/ch3_sine_1hz.nc: ")
    assert "unreadable capture" in line or "not a readable" in line or "time axis" in line, line
    assert (
        "ERROR raw/pi_p885/ch3_sine_1hz.nc: "
        in (repo / "logs" / "pi_p885" / "extract_ripple" / "ch3_sine_1hz.log").read_text()
    )


@pytest.mark.slow
def test_a_dash_dash_config_fault_is_blamed_on_it_by_snakemake(tmp_path):
    repo = copy_repo(tmp_path / "repo")
    # no --configfile: the fault is in --config alone, over the repository's config.yaml
    run = run_snakemake(repo, "-n", "--config", "campain=smoke", config=None, cores=1, timeout=600)
    assert run.returncode != 0
    line = error_line(run, "unknown key campain")
    assert "--config: unknown key campain" in line and "config.yaml" not in line, line
