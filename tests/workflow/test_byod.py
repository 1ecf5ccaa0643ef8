"""Bring your own data (docs/bring-your-own-data.md), end to end: a lab's CSV imported with
`selfsense import` gets its table, figure and a scorecard of its own, and a capture that contradicts
its manifest stops the run; a measured copy of the smoke bench (its captures without /truth) runs
every analysis and remakes the simulated dataset's tables byte for byte. The importer, the
analyses and the checks on small inputs are in tests/unit/test_byod.py.
"""

import netCDF4
import numpy as np
import pandas as pd
import pytest
import yaml

from selfsense.io.manifest import load_yaml
from selfsense.scorecard.registry import PUBLISHED, WITHIN

from ..helpers import (
    LAB_PHI,
    ROOT,
    copy_repo,
    imported,
    measured_copy_remakes,
    run_snakemake,
    write_config,
    write_csv,
)


def copy_without_truth(src, dst, dataset):
    """A capture as a lab's DAQ would have written it: the same channels and attributes, no
    /truth."""
    with netCDF4.Dataset(src) as a, netCDF4.Dataset(dst, "w", format="NETCDF4") as b:
        b.setncatts(
            {k: a.getncattr(k) for k in a.ncattrs()} | {"dataset": dataset, "source": "measured"}
        )
        for name, dim in a.dimensions.items():
            b.createDimension(name, len(dim))
        for name, var in a.variables.items():
            var.set_auto_maskandscale(False)
            attrs = {k: var.getncattr(k) for k in var.ncattrs()}
            out = b.createVariable(
                name,
                var.dtype,
                var.dimensions,
                zlib=True,
                complevel=1,
                fill_value=attrs.pop("_FillValue", None),
            )
            out.set_auto_maskandscale(False)
            out.setncatts(attrs)
            out[:] = var[:]


@pytest.fixture(scope="module")
def measured_bench(smoke_run, tmp_path_factory):
    """Every smoke capture of the ripple bench, /truth removed, as the measured dataset bench_lab
    (the stack's manifest without its twin), run through the whole DAG."""
    repo = copy_repo(tmp_path_factory.mktemp("lab") / "repo")
    folder = repo / "raw" / "bench_lab"
    folder.mkdir()
    # in the simulated dataset's order, which the tables' rows follow
    runs = list(
        pd.read_csv(smoke_run / "results" / "pi_p885" / "qc" / "captures.csv")["experiment"]
    )
    assert sorted(runs) == sorted(p.stem for p in (smoke_run / "raw" / "pi_p885").glob("*.nc"))
    for run in runs:
        copy_without_truth(
            smoke_run / "raw" / "pi_p885" / f"{run}.nc", folder / f"{run}.nc", "bench_lab"
        )
    doc = {
        k: v
        for k, v in load_yaml(ROOT / "raw" / "pi_p885" / "dataset.yaml").items()
        if k not in ("twin", "seed")
    }
    doc |= {"name": "bench_lab", "source": "measured", "experiments": runs}
    (folder / "dataset.yaml").write_text(yaml.safe_dump(doc, sort_keys=False, allow_unicode=True))
    # six captures a characterise job, as the simulated bench: the per-capture jobs of a measured
    # dataset (test_batches.py) would be ≈ 50 of this DAG's jobs, each starting Python
    pages = {"captures_per_job": {"simulated": 6, "measured": 6}}
    config = write_config(repo, "lab", ["bench_lab"], characterise=pages)
    run = run_snakemake(repo, config=config)
    return repo, run, smoke_run


@pytest.mark.slow
def test_a_measured_ripple_bench_runs_every_analysis_to_the_end(measured_bench):
    repo, run, smoke = measured_bench
    assert run.returncode == 0, run.stderr[-4000:]
    res = repo / "results" / "bench_lab"
    coupled = pd.read_csv(res / "ch7" / "coupled.csv")
    assert len(coupled) == 3
    for n in (10, 11, 12):
        assert (repo / "figures" / "bench_lab" / f"fig_7_{n}.png").exists()
    # the same samples (written again with zlib, without /truth) give every table the simulated
    # dataset's DAG made, byte for byte: both the reproduction's determinism and its independence
    # of the capture's compression (the rebuild test remakes the tables this cannot)
    remade = sorted(str(p.relative_to(res)) for p in res.rglob("*.csv"))
    expected = sorted(
        str(p.relative_to(smoke / "results" / "pi_p885"))
        for p in (smoke / "results" / "pi_p885").rglob("*.csv")
        if measured_copy_remakes(str(p.relative_to(smoke)))
    )
    assert sorted(set(remade) - {"scorecard.csv", "stages.csv"}) == expected
    assert [
        t
        for t in expected
        if (res / t).read_bytes() != (smoke / "results" / "pi_p885" / t).read_bytes()
    ] == []
    # the same published numbers as the simulated dataset, and no twin recovery
    card = pd.read_csv(res / "scorecard.csv")
    twin = pd.read_csv(smoke / "results" / "pi_p885" / "scorecard.csv")
    twin = twin[twin["section"] == PUBLISHED].reset_index(drop=True)
    assert (card["section"] == PUBLISHED).all()
    pd.testing.assert_series_equal(card["reproduced"], twin["reproduced"])
    # a band centred on the model on the twin's truth has no truth to be centred on here: it is
    # the published value's; every other band and verdict is the simulated dataset's
    centred = twin["band"] == "model on truth"
    assert centred.any() and (card.loc[~centred, "verdict"] == twin.loc[~centred, "verdict"]).all()
    assert (card["verdict"] == WITHIN).sum() > 0
    mid = (card.loc[centred, "band low"] + card.loc[centred, "band high"]) / 2
    assert mid.to_numpy() == pytest.approx(card.loc[centred, "published"].to_numpy(), rel=1e-12)
    assert not (res / "twin").exists()  # every step that reads /truth is absent, not failed
    stages = pd.read_csv(res / "stages.csv").set_index("stage")
    assert (
        stages.drop("powerloss (Ronkanen)")["status"] == "runs"
    ).all()  # every thesis stage, to the end
    captures = sorted(p.stem for p in (repo / "raw" / "bench_lab").glob("*.nc"))
    assert sorted(pd.read_csv(res / "characterise" / "summary.csv")["experiment"]) == captures


@pytest.fixture(scope="module")
def lab_csv(tmp_path_factory):
    """A U–x CSV imported into a scratch copy as lab_stack (no model, a data sheet's stroke), and
    a second import whose manifest was then edited to another fs (lab_fs)."""
    repo = copy_repo(tmp_path_factory.mktemp("csv") / "repo")
    source = write_csv(repo / "sine.csv")
    for dataset in ("lab_stack", "lab_fs"):
        imported(
            repo,
            source,
            "U=U [V]:V",
            "x_laser=x [um]:um",
            dataset=dataset,
            extra=["--time", "t [s]:s"],
        )
    path = repo / "raw" / "lab_stack" / "dataset.yaml"
    path.write_text(
        path.read_text()
        + "reference:\n  stroke_um: {value: 31, tolerance_percent: 10, source: data sheet}\n"
        "sensors:\n  x_laser: {type: laser vibrometer, resolution: 3.0e-7, units: m}\n"
    )
    path = repo / "raw" / "lab_fs" / "dataset.yaml"
    path.write_text(path.read_text().replace("fs: 5000.0", "fs: 5120.0"))
    good = run_snakemake(repo, config=write_config(repo, "good", ["lab_stack"]))
    bad = run_snakemake(repo, config=write_config(repo, "bad", ["lab_fs"]))
    return repo, good, bad


@pytest.mark.slow
def test_an_imported_csv_gets_its_table_figure_and_a_scorecard_of_its_own(lab_csv):
    repo, good, _ = lab_csv
    assert good.returncode == 0, good.stderr[-4000:]
    res = repo / "results" / "lab_stack"
    table = pd.read_csv(res / "characterise" / "summary.csv")
    assert list(table["experiment"]) == ["sine_1hz"]
    assert abs(table.loc[0, "x–U loop width [% of stroke]"] - 100 * np.sin(LAB_PHI)) < 0.5
    # a measured dataset's loop figure: a page per capture, named after it
    assert (repo / "figures" / "lab_stack" / "characterise" / "loops_sine_1hz.png").exists()
    sensors = pd.read_csv(res / "characterise" / "instruments.csv").set_index(["item", "property"])[
        "value"
    ]
    assert sensors[("channel x_laser", "type")] == "laser vibrometer"
    card = pd.read_csv(res / "scorecard.csv")  # no published rows: the data sheet's stroke only
    assert list(card["section"]) == ["reference values"] and list(card["verdict"]) == [WITHIN]
    stages = pd.read_csv(res / "stages.csv").set_index("stage")
    assert stages.loc["characterise", "status"] == "runs"
    assert (
        "this dataset lacks: channel Ur, channel Ir, channel I, daq.ripple"
        in stages.loc["ripple (Ch. 3)", "needs"]
    )


@pytest.mark.slow
def test_a_capture_that_contradicts_its_manifest_stops_the_run_and_its_log_says_why(lab_csv):
    repo, _, bad = lab_csv
    assert bad.returncode != 0
    reason = (
        "raw/lab_fs/sine_1hz.nc: fs = 5000 Hz, the manifest declares daq.fs = 5120 Hz"
        " (raw/lab_fs/dataset.yaml)"
    )
    assert reason in bad.stdout + bad.stderr
    assert reason in (repo / "logs" / "lab_fs" / "check_capture" / "sine_1hz.log").read_text()
    assert not (repo / "results" / "lab_fs" / "qc" / "sine_1hz.json").exists()
