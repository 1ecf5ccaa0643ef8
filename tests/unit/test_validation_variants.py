"""The twin's variants chosen by the data they are not judged on, with known truth: an analytic
simulator of three unknowns and two variant keys, v (which the bench has: it moves a row of
fold B and a row of fold C) and w (which acts on nothing). Today's twin (v = w = 0) fails every
fold (B and C cannot both be met, and A, predicted from them, is pulled off); the variant v
holds every fold, each predicted from the others, and breaks nothing; w changes nothing, so it
is not supported. The variant validation's bookkeeping: the models' held inputs,
the joined runs' unknowns at their nominal, design points never shared across validations."""

import math

import numpy as np
import pandas as pd
import pytest

from selfsense.envelope import campaign
from selfsense.envelope.campaign import ALL, TODAY, over_inputs, variant_models
from selfsense.envelope.fold_prediction import INCONSISTENT
from selfsense.envelope.judgement import ensemble
from selfsense.envelope.unknowns import Unknown
from selfsense.envelope.validation import Declaration, Fold, Row, Target
from selfsense.envelope.variant_choice import FAILS, HOLDS, choose, supported
from tests.unit.test_validation_judgement import EMULATOR

IDS = ["u1", "u2", "u3", "v", "w"]
TRUTH = np.array([[0.3, 0.6, 0.4, 0.5, 0.0]])
NOISE, DIGIT, MD = 0.02, 0.01, 0.06
SD = math.sqrt(DIGIT**2 / 12)
WAVES = {
    "seed": 11,
    "first": {"runs": 60, "maximin_candidates": 5, "replicates": {"points": 5, "seeds": 3}},
}
ROWS = {
    ("A", "a1"): lambda x: np.sin(2 * x[:, 0]),
    ("A", "a2"): lambda x: x[:, 0] * x[:, 1] + x[:, 2],
    ("B", "b1"): lambda x: x[:, 1] ** 2 + x[:, 3],
    ("B", "b2"): lambda x: x[:, 1] - 0.5 * x[:, 2],
    ("C", "c1"): lambda x: x[:, 0] - x[:, 1] + x[:, 3],
}
TARGETS = {"t1": lambda x: x[:, 0] + x[:, 1], "t2": lambda x: x[:, 2]}


def unknown(uid: str, group: str, variant: bool) -> Unknown:
    return Unknown(uid, "synthetic", group, (uid,), 0.0, 0.0, 1.0, "uniform", "1", (), "test",
                   variant=variant)  # fmt: skip


def published(f):
    return round(float(f(TRUTH)[0]), 2)


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
        "prediction": {"samples": 8192, "quantiles": [0.025, 0.5, 0.975]},
        "variants": {"rows": {"select": [{"source": "Table X", "quantity": "c1"}]}},
    }
    return Declaration(2, "2026-12-02", "synthetic", 3.0, 10, {}, tuple(folds), targets, settings)


def tables(runs):
    inputs = campaign.run_frame(runs, np.arange(len(runs)), "syn", IDS, "smoke")
    noise = np.array(
        [np.random.default_rng(int(s)).standard_normal(len(ROWS) + len(TARGETS)) for s in runs.seed]
    )
    rows = pd.DataFrame(
        {campaign.row_key("Table X", q): f(runs.unit) for (_, q), f in ROWS.items()}
    )
    rows = rows + NOISE * noise[:, : len(ROWS)]
    targets = pd.DataFrame({t: f(runs.unit) for t, f in TARGETS.items()})
    targets = targets + NOISE * noise[:, len(ROWS) :]
    rows.insert(0, "member", inputs["member"])
    targets.insert(0, "member", inputs["member"])
    return inputs, rows, targets


@pytest.fixture(scope="module")
def chosen():
    prior = [unknown(u, "base", False) for u in IDS[:3]]
    prior += [unknown("v", "the term v", True), unknown("w", "the term w", True)]
    models = variant_models(prior, {"the term v": {}, "the term w": {}}, held=[])
    inputs, rows, targets = tables(campaign.first_wave(WAVES, len(IDS)))
    return models, choose(declaration(), [], IDS, inputs, rows, targets, models)


def test_the_models_hold_the_other_variants_off():
    prior = [unknown("u1", "base", False), unknown("v", "g", True), unknown("w", "h", True)]
    held = [unknown("gain", "chain", False)]
    models = {m.name: m.fixed for m in variant_models(prior, {"g": {"holds": ["gain"]}}, held)}
    assert list(models) == [TODAY, "g", ALL]
    assert models[TODAY] == {"v": 0.0}  # w's group is not varied: no key of it in the prior
    assert models["g"] == {"gain": 0.0} and models[ALL] == {"gain": 0.0}


def test_a_variant_the_bench_has_reconciles_the_folds_it_moves_from_the_others(chosen):
    models, choice = chosen
    states = choice.folds
    # folds A, B, C: without v, B and C cannot both be met, and A, conditioned on them, fails
    assert list(states[TODAY]) == [FAILS, FAILS, FAILS]
    assert list(states["the term v"]) == [HOLDS, HOLDS, HOLDS]
    assert list(states["the term w"]) == [FAILS, FAILS, FAILS]
    assert supported(states) == ["the term v", ALL]
    c1 = choice.rows.set_index("model")
    assert c1.loc[TODAY, "verdict"] == INCONSISTENT
    assert (
        c1.loc["the term v", "p2.5"] <= published(ROWS["C", "c1"]) <= c1.loc["the term v", "p97.5"]
    )
    assert "the term v: holds 3" in choice.summary and "reconciles A, B, C" in choice.summary


def test_the_joined_runs_hold_what_they_did_not_vary_at_its_nominal_and_never_replicate():
    runs = campaign.first_wave(WAVES, 3)
    base = campaign.run_frame(runs, np.arange(len(runs)), "base", IDS[:3], "smoke")
    own = campaign.run_frame(runs, np.arange(len(runs)), "var", IDS[:3], "smoke")
    joined = over_inputs(pd.concat([base, own], ignore_index=True), IDS, {"v": 0.25, "w": 0.0})
    assert (joined["v"] == 0.25).all() and list(joined.columns[-5:]) == IDS
    decl = declaration()
    blank = pd.DataFrame({"member": joined["member"]})
    ens = ensemble(decl, IDS, joined, blank, blank)
    # the same wave and point numbers in two validations are two design points
    assert len(set(ens.point)) == 2 * len(set(runs.point))
