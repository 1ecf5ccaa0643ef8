"""The validation's runs as members: wave 1 is the declared design with the declared replicates
and the same noise seeds run_waves gives, in batches cut in run order; a done batch that is not
the current draw is refused in one line; the common targets are located in a member's tables;
the config section is bounded where it is read."""

import numpy as np
import pandas as pd
import pytest

from selfsense.envelope import campaign
from selfsense.envelope.emulator import Settings
from selfsense.envelope.history_matching import run_waves, streams
from selfsense.io.manifest import ManifestError

WAVES = {
    "seed": 11,
    "first": {"runs": 12, "maximin_candidates": 4, "replicates": {"points": 3, "seeds": 3}},
}


def test_wave_one_is_the_declared_design_with_its_replicates_first():
    runs = campaign.first_wave(WAVES, d=4)
    assert len(runs) == 12 + 3 * 2
    # the replicate points, then their two rounds of replicates, then the other points
    assert list(runs.point[:9]) == [0, 1, 2] * 3
    assert list(runs.replicate[:9]) == [0] * 3 + [1] * 3 + [2] * 3
    assert list(runs.point[9:]) == list(range(3, 12))
    # a replicate is its point run again with a fresh seed: the seed is noise, not a factor
    np.testing.assert_array_equal(runs.unit[3], runs.unit[0])
    assert len(set(runs.seed)) == len(runs)


def test_wave_one_runs_what_run_waves_runs_on_the_same_declaration():
    seen = []

    def simulate(X, seeds):
        seen.extend(zip(map(tuple, X), seeds))
        return np.column_stack([X.sum(axis=1)])

    run_waves(
        simulate, 4, np.array([2.0]), np.array([2.0]), np.array([0.01]), cutoff=3.0,
        second_maximum_from=10, first_runs=12, later_runs=4, replicate_points=3,
        replicate_seeds=3, candidates=256, max_waves=1, shrink_below=0.2, seed=11,
        settings=Settings(restarts=0), maximin_candidates=4,
    )  # fmt: skip
    runs = campaign.first_wave(WAVES, d=4)
    ours = sorted(zip(map(tuple, runs.unit), runs.seed))
    assert ours == sorted((x, int(s)) for x, s in seen)


def test_batches_are_cut_in_run_order_and_named_by_run():
    runs = campaign.first_wave(WAVES, d=4).head(7)
    cut = campaign.batches(runs, "pi_p885_validation", 3)
    assert [b.id for b in cut] == ["wave1/batch01", "wave1/batch02", "wave1/batch03"]
    assert cut[0].members == tuple(f"pi_p885_validation~00{i}" for i in (1, 2, 3))
    assert cut[-1].members == ("pi_p885_validation~007",)


def test_a_done_batch_from_another_draw_is_refused_in_one_line(tmp_path):
    runs = campaign.first_wave(WAVES, d=4)
    expected = campaign.run_frame(runs, np.arange(3), "v", ["a", "b", "c", "d"], "smoke")
    expected.to_csv(tmp_path / "inputs.csv", index=False)
    campaign.check_done(tmp_path, expected)  # the current draw: done
    changed = expected.copy()
    changed.loc[1, "seed"] += 1
    changed.to_csv(tmp_path / "inputs.csv", index=False)
    with pytest.raises(ManifestError) as err:
        campaign.check_done(tmp_path, expected)
    assert str(err.value).startswith(f"{tmp_path / 'inputs.csv'}: its seeds are not")
    assert "\n" not in str(err.value)
    expected.assign(campaign="thesis").to_csv(tmp_path / "inputs.csv", index=False)
    with pytest.raises(ManifestError, match="made on campaign 'thesis'"):
        campaign.check_done(tmp_path, expected)


def test_a_target_is_located_in_a_members_tables():
    table = pd.DataFrame(
        {
            "error": ["e_TCL", "e_TCL", "e_TOL"],
            "statistic": ["max", "σ", "max"],
            "a [µm]": [1.5, 0.2, 9.0],
            "b [µm]": [2.5, 0.1, 9.0],
        }
    )
    tables = {"ch6/table_6_1.csv": table}
    locate = {
        "table": "ch6/table_6_1.csv",
        "column": ["a [µm]", "b [µm]"],
        "where": {"error": "e_TCL", "statistic": "max"},
        "reduce": "max",
    }
    assert campaign.locate_value(locate, tables) == 2.5
    one = {"table": "ch6/table_6_1.csv", "column": "a [µm]", "where": {"statistic": "σ"}}
    assert campaign.locate_value(one, tables) == 0.2
    assert np.isnan(campaign.locate_value({**one, "table": "ch5/none.csv"}, tables))
    assert np.isnan(campaign.locate_value({**one, "column": "z [µm]"}, tables))
    assert np.isnan(campaign.locate_value({**one, "where": {"error": "e_TCL"}}, tables))


def test_a_member_whose_analysis_failed_gives_no_value_and_names_the_step():
    card = pd.DataFrame(
        {"kind": ["emergent"], "source": ["Table 5.1"], "quantity": ["R²"], "reproduced": [0.99]}
    )
    inputs = pd.DataFrame({"member": ["v~001", "v~002"]})
    locate = {"table": "ch5/t.csv", "column": "df", "where": {"source": "Total"}}
    tables = {"v~001": {"ch5/t.csv": pd.DataFrame({"source": ["Total"], "df": [14374]})}}
    failed = {"v~002": "rule charge_sensing (…): ValueError: a0 must be > 0"}
    rows, targets = campaign.batch_tables(
        inputs, {"v~001": card}, tables, ["Table 5.1 · R²"], [("df", locate)], failed
    )
    assert list(rows["member"]) == ["v~001", "v~002"]
    assert rows["Table 5.1 · R²"].iloc[0] == 0.99 and np.isnan(rows["Table 5.1 · R²"].iloc[1])
    assert list(rows[campaign.FAILED_COLUMN]) == ["", failed["v~002"]]
    assert targets["df"].iloc[0] == 14374 and np.isnan(targets["df"].iloc[1])


SECTION = {"dataset": "pi_p885", "name": "", "waves": 1, "members": 0, "batch": 20,
           "batches": 0, "stages": ["ripple"]}  # fmt: skip


def test_the_plan_names_its_members_after_the_dataset_by_default():
    plan = campaign.Plan.from_config(SECTION)
    assert plan.name == "pi_p885_validation"
    assert campaign.Plan(**plan.record()).record() == plan.record()


@pytest.mark.parametrize("name", ["../x", "a" * 65, "pi p885", "x\n"])
def test_a_name_that_is_no_dataset_name_is_refused_in_one_line(name):
    with pytest.raises(ManifestError) as err:
        campaign.Plan.from_config({**SECTION, "name": name})
    assert str(err.value).startswith("config.yaml: key validation.name: ")
    assert "\n" not in str(err.value)


@pytest.mark.parametrize(
    ("targets", "asked"),
    [
        ((), False),  # the default run
        (("all", "envelope", "results/pi_p885~07/scorecard.csv"), False),
        (("validate",), True),
        (("results/validation/pi_p885_validation/verdicts.csv",), True),
        (("results/pi_p885_validation~003/scorecard.csv",), True),
    ],
)
def test_members_are_drawn_only_for_a_target_that_needs_them(targets, asked):
    assert campaign.asked(targets, "pi_p885_validation") is asked


def test_the_seeds_come_from_the_waves_one_stream():
    runs = campaign.first_wave(WAVES, d=4)
    drawn = streams(11)
    assert runs.seed[0] == drawn.runs[0] and runs.seed[3] == drawn.runs[12]


def test_the_snapshot_keeps_every_done_batch_and_the_verdicts_not_a_batch_left_unfinished(
    tmp_path,
):
    from ..helpers import ROOT, load_module

    update_docs = load_module(ROOT / "scripts" / "update_docs.py")
    folder = tmp_path / "results" / "validation" / "v"
    done, half = folder / "wave1" / "batch01", folder / "wave1" / "batch02"
    for batch, names in ((done, campaign.TABLES.values()), (half, ["inputs.csv"])):
        batch.mkdir(parents=True)
        for name in names:
            (batch / name).write_text("member\n")
            (batch / f"{name}.json").write_text("{}\n")
    (folder / "verdicts.csv").write_text("verdict\n")
    target = update_docs.snapshot_validation(folder, tmp_path / "snapshot")
    assert target == tmp_path / "snapshot" / "validation" / "v"
    assert sorted(p.name for p in (target / "wave1" / "batch01").iterdir()) == sorted(
        [*campaign.TABLES.values(), *(f"{n}.json" for n in campaign.TABLES.values())]
    )
    assert not (target / "wave1" / "batch02").exists()
    assert (target / "verdicts.csv").is_file()


def test_the_prior_holds_the_twins_variants_off_and_draws_every_other_unknown():
    from pathlib import Path

    from selfsense.envelope.unknowns import load_unknowns

    root = Path(__file__).resolve().parents[2]
    declared = load_unknowns(root / "workflow" / "unknowns.yaml", raw_dir=root / "raw")
    prior, seed = campaign.varied(declared, "pi_p885")
    variants = [u for u in declared if u.variant and "pi_p885" in u.datasets]
    assert variants and not {u.id for u in variants} & {u.id for u in prior}
    assert seed is not None and seed.paths == ("seed",)
    others = [u for u in declared if "pi_p885" in u.datasets and not u.in_model and not u.variant]
    assert len(prior) == len(others) - 1  # all but the seed, which is noise


def test_the_declared_variants_join_the_prior_and_what_they_hold_leaves_it():
    from pathlib import Path

    from selfsense.envelope.unknowns import load_unknowns
    from selfsense.envelope.validation import load_validation

    root = Path(__file__).resolve().parents[2]
    declared = load_unknowns(root / "workflow" / "unknowns.yaml", raw_dir=root / "raw")
    groups = load_validation(root / "workflow" / "validation.yaml").settings["variants"]["groups"]
    base, _ = campaign.varied(declared, "pi_p885")
    prior, _ = campaign.varied(declared, "pi_p885", groups)
    held = {h for g in groups.values() for h in g.get("holds", ())}
    keys = {u.id for u in declared if u.variant and u.group in groups}
    assert held and held <= {u.id for u in base}
    assert {u.id for u in prior} == ({u.id for u in base} - held) | keys
    with pytest.raises(ManifestError, match="variants.groups.mechanics: no variant group"):
        campaign.varied(declared, "pi_p885", {"mechanics": {}})
    with pytest.raises(ManifestError, match="holds: k_stack is not in the prior"):
        campaign.varied(declared, "pi_p885", {"amplifier": {"holds": ["k_stack"]}})


def test_a_variant_validations_bad_plan_is_refused_in_one_line(tmp_path):
    from pathlib import Path

    from selfsense.envelope.validation import load_validation

    root = Path(__file__).resolve().parents[2]
    decl = load_validation(root / "workflow" / "validation.yaml")
    plan = campaign.Plan("pi_p885", "v", 2, 0, 20, 1, (), variants=True)
    with pytest.raises(ManifestError, match="validation.waves: 2 is more than the 1 waves"):
        campaign.draw(plan, decl, {}, [], "smoke", tmp_path, tmp_path / "snap" / "v")
    with pytest.raises(ManifestError, match="validation.joins: nothing has no committed batch"):
        campaign.joined_batches(tmp_path, "nothing")
    (tmp_path / "half" / "wave1" / "batch01").mkdir(parents=True)
    (tmp_path / "half" / "wave1" / "batch01" / "inputs.csv").write_text("member\n")
    with pytest.raises(ManifestError, match="half has no committed batch"):  # not all four
        campaign.joined_batches(tmp_path, "half")
