"""The validation's verdicts from the tables alone: a small synthetic ensemble (an analytic
simulator with seed noise, three unknowns, two common targets and five rows in three folds) in
the tables `snakemake validate` keeps, judged with no simulation. The same tables give the same
verdicts twice; a changed table gives other verdicts; a later wave's design reads the common
targets only."""

import math

import numpy as np
import pandas as pd
import pytest

from selfsense.envelope import campaign
from selfsense.envelope.fold_prediction import CONSISTENT, INCONSISTENT, UNINFORMATIVE
from selfsense.envelope.judgement import ensemble, judge, next_wave, replicate_variance
from selfsense.envelope.validation import Declaration, Fold, Row, Target

IDS = ["u1", "u2", "u3"]
TRUTH = np.array([0.3, 0.6, 0.4])
NOISE, DIGIT, MD = 0.03, 0.01, 0.02
WAVES = {
    "seed": 7,
    "first": {"runs": 30, "maximin_candidates": 5, "replicates": {"points": 5, "seeds": 3}},
    "later": {
        "runs": 12,
        "candidates": 4096,
        "maximin_candidates": 5,
        "replicates": {"points": 2, "seeds": 2},
    },
    "stop": {"max_waves": 3, "nroy_shrink_below": 0.01, "emulator_to_other_variance_below": 1e-9},
}
EMULATOR = {
    "kernel": "matern",
    "nu": 2.5,
    "mean": "linear",
    "nugget": {"initial": 0.01, "bounds": [1e-8, 1.0]},
    "length_scale_bounds": [0.01, 100.0],
    "restarts": 0,
    "active_inputs": {"max": 3, "min_total_index": 0.02},
    "leave_one_out": {
        "threshold": 3,
        "max_fraction_beyond": 0.1,
        "coverage95_min": 0.8,
        "min_q2": 0.5,
    },
}
#: (fold, row) → the simulator's expected value
ROWS = {
    ("A", "a1"): lambda x: np.sin(2 * x[:, 0]),
    ("A", "a2"): lambda x: x[:, 0] * x[:, 1] + x[:, 2],
    ("B", "b1"): lambda x: x[:, 1] ** 2,
    ("B", "b2"): lambda x: x[:, 1] - 0.5 * x[:, 2],
    ("C", "c1"): lambda x: x[:, 0] - x[:, 1],
}
TARGETS = {"t1": lambda x: x[:, 0] + x[:, 1], "t2": lambda x: x[:, 2]}
SD = math.sqrt(DIGIT**2 / 12)


def published(f):
    return round(float(f(TRUTH[None, :])[0]), 2)


def declaration():
    folds = []
    for fold in ("A", "B", "C"):
        rows = tuple(
            Row(fold, "Table X", q, "1", published(f), "value", "identity", published(f),
                published(f), SD, MD, (published(f) - 0.05, published(f) + 0.05), True, True)
            for (fd, q), f in ROWS.items()
            if fd == fold
        )  # fmt: skip
        folds.append(Fold(fold, f"fold {fold}", (fold.lower(),), rows))
    targets = tuple(
        Target(tid, "printed", tid, "1", "value", "identity", published(f), published(f), SD, MD,
               ("t",), {"table": "t.csv", "column": tid}, "synthetic")
        for tid, f in TARGETS.items()
    )  # fmt: skip
    settings = {
        "waves": WAVES,
        "emulator": EMULATOR,
        "prediction": {"samples": 512, "quantiles": [0.025, 0.5, 0.975]},
        "pseudo_theses": {"count": 6, "seed": 3, "nominal": 0.95},
    }
    return Declaration(1, "2026-12-01", "synthetic", 3.0, 10, {}, tuple(folds), targets, settings)


def tables(runs):
    """members × inputs, rows and targets of the runs, each run's noise from its own seed."""
    inputs = campaign.run_frame(runs, np.arange(len(runs)), "syn", IDS, "smoke")
    noise = np.array(
        [np.random.default_rng(int(s)).standard_normal(len(ROWS) + len(TARGETS)) for s in runs.seed]
    )
    rows = {campaign.row_key("Table X", q): f(runs.unit) for (_, q), f in ROWS.items()}
    rows = pd.DataFrame(rows) + NOISE * noise[:, : len(ROWS)]
    targets = pd.DataFrame({t: f(runs.unit) for t, f in TARGETS.items()})
    targets = targets + NOISE * noise[:, len(ROWS) :]
    rows.insert(0, "member", inputs["member"])
    targets.insert(0, "member", inputs["member"])
    return inputs, rows, targets


@pytest.fixture(scope="module")
def setting():
    decl = declaration()
    runs = campaign.first_wave(WAVES, len(IDS))
    inputs, rows, targets = tables(runs)
    return decl, inputs, rows, targets, judge(decl, [], IDS, inputs, rows, targets)


def test_the_same_tables_give_the_same_verdicts_twice(setting):
    decl, inputs, rows, targets, first = setting
    again = judge(decl, [], IDS, inputs, rows, targets)
    pd.testing.assert_frame_equal(first.verdicts, again.verdicts)
    pd.testing.assert_frame_equal(first.coverage, again.coverage)
    assert first.summary == again.summary
    # the synthetic twin is right, so its rows are predicted and consistent with their values
    assert set(first.verdicts["verdict"]) <= {CONSISTENT, UNINFORMATIVE}
    assert first.emulators["emulable"].all()
    assert len(first.coverage) == 6  # the declared pseudo-theses: runs alone at their point


def test_a_changed_table_changes_the_verdicts_without_a_run(setting):
    decl, inputs, rows, targets, first = setting
    shifted = rows.copy()
    key = campaign.row_key("Table X", "c1")
    shifted[key] = shifted[key] + 1.0  # the ensemble now says c1 lies a whole unit higher
    other = judge(decl, [], IDS, inputs, shifted, targets)
    before = first.verdicts.set_index("quantity")
    after = other.verdicts.set_index("quantity")
    assert before.loc["c1", "verdict"] != INCONSISTENT
    assert after.loc["c1", "verdict"] == INCONSISTENT
    assert after.loc["c1", "p50"] == pytest.approx(before.loc["c1", "p50"] + 1.0, abs=0.1)


def test_the_replicates_measure_the_seeds_noise(setting):
    decl, inputs, rows, targets, _ = setting
    ens = ensemble(decl, IDS, inputs, rows, targets)
    var, df = replicate_variance(ens.Y, ens.wave, ens.point)
    assert (df == 5 * 2).all()  # 5 points run 3 times: 2 degrees of freedom each
    assert np.sqrt(var) == pytest.approx(np.full(len(var), NOISE), rel=0.6)


def test_a_later_wave_reads_the_common_targets_only_and_samples_inside_what_they_leave(setting):
    decl, inputs, rows, targets, _ = setting
    ens = ensemble(decl, IDS, inputs, rows, targets)
    runs, fractions, stopped = next_wave(ens, decl, len(IDS), first=len(inputs))
    assert stopped == "" and 0 < fractions[0] < 1
    assert len(runs) == 12 + 2 and runs.wave == 2
    # the rows do not steer it: other rows, the same design
    garbage = rows.copy()
    garbage.iloc[:, 1:] = 1e3
    other, _, _ = next_wave(ensemble(decl, IDS, inputs, garbage, targets), decl, 3, len(inputs))
    np.testing.assert_array_equal(runs.unit, other.unit)
    # inside what the targets leave: t1 = u1 + u2 and t2 = u3 near the truth's
    t1 = runs.unit[:, 0] + runs.unit[:, 1]
    assert np.all(np.abs(t1 - TRUTH[:2].sum()) < 0.35)
    assert np.all(np.abs(runs.unit[:, 2] - TRUTH[2]) < 0.35)
    # their noise seeds follow wave 1's in the waves' one stream
    assert len(set(runs.seed) & set(inputs["seed"])) == 0
