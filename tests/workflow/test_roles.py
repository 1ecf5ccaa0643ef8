"""A lab's own runs through the stages by role (docs/adding-a-dataset.md, "Your own run names"):
a measured dataset holding some of the thesis's runs, under its own names mapped onto the
catalogue's roles, gets every stage its roles allow, with the tables the simulated dataset makes
from the same samples, and a "lacks" row naming the missing role for every other stage — no
KeyError, no missing input. The role accessors and the mapping's errors are in
tests/unit/test_roles.py."""

import pandas as pd
import pytest
import yaml

from selfsense.io.manifest import load_yaml
from selfsense.io.roles import ROLES

from ..helpers import ROOT, copy_repo, run_snakemake, write_config
from .test_byod import copy_without_truth

#: {the lab's run: the smoke bench's capture it is}: Chapter 3's three series and the 0.1 Hz sine
#: Γ is fitted on; no Chapter 4 sets, no creep run
LAB_RUNS = {
    "sweep_a": "ch3_sine_10hz",
    "sweep_b": "ch3_sine_1hz",
    "sweep_c": "ch3_sine_0p1hz",
    "slow_sine": "ch5_sine_0p1hz",
}
#: the lab's manifest maps them onto roles as docs/adding-a-dataset.md shows
LAB_ROLES = {
    "ch3.series_10hz": "sweep_a",
    "ch3.series_1hz": "sweep_b",
    "ch3.series_0p1hz": "sweep_c",
    "gamma.fit": "slow_sine",
}


@pytest.fixture(scope="module")
def lab_roles(smoke_run, tmp_path_factory):
    """The lab's dataset lab_roles, its captures the smoke bench's without /truth, run whole."""
    repo = copy_repo(tmp_path_factory.mktemp("roles") / "repo")
    folder = repo / "raw" / "lab_roles"
    folder.mkdir()
    for run, capture in LAB_RUNS.items():
        copy_without_truth(
            smoke_run / "raw" / "pi_p885" / f"{capture}.nc", folder / f"{run}.nc", "lab_roles"
        )
    doc = {
        k: v
        for k, v in load_yaml(ROOT / "raw" / "pi_p885" / "dataset.yaml").items()
        if k not in ("twin", "seed")
    }
    doc |= {"name": "lab_roles", "source": "measured", "experiments": list(LAB_RUNS)}
    doc["roles"] = LAB_ROLES
    (folder / "dataset.yaml").write_text(yaml.safe_dump(doc, sort_keys=False, allow_unicode=True))
    config = write_config(repo, "lab", ["lab_roles"])
    dry = run_snakemake(repo, "-n", config=config)
    return repo, dry, run_snakemake(repo, config=config), smoke_run


@pytest.mark.slow
def test_a_labs_own_run_names_get_every_stage_their_roles_allow(lab_roles):
    repo, dry, run, smoke = lab_roles
    assert dry.returncode == 0, dry.stderr[-3000:]
    assert run.returncode == 0, run.stderr[-3000:]
    assert "KeyError" not in run.stderr + dry.stderr
    plan = pd.read_csv(repo / "results" / "lab_roles" / "stages.csv").set_index("stage")
    running = {"characterise", "ripple (Ch. 3)", "hysteresis and figures (Ch. 3)", "gamma (Ch. 5)"}
    assert set(plan.index[plan["status"] == "runs"]) == running
    # a skipped stage names the roles it has no run of, in the catalogue's words
    lacks = plan.loc["identify (Ch. 4)", "needs"]
    assert f"role identify.set ({ROLES['identify.set']})" in lacks
    observer = plan.loc["observer (Ch. 5)", "needs"]
    assert "role observer.creep" in observer and "role observer.sine" in observer
    assert "the observer stage" in plan.loc["control (Ch. 6)", "needs"]
    # the same samples under other names give the simulated dataset's tables, byte for byte
    for table in ("ch5/table_5_1.csv", "ch3/hysteresis.csv", "ch3/phases.csv"):
        mine = repo / "results" / "lab_roles" / table
        assert mine.read_bytes() == (smoke / "results" / "pi_p885" / table).read_bytes(), table
    assert (repo / "figures" / "lab_roles" / "fig_3_10.png").exists()
