"""The reproduction envelope: SALib's draws mapped through each unknown's distribution, the Morris
design's one-group-at-a-time steps and the Latin hypercube's strata, a member's manifest and
protocol overrides (and what the stage plan makes of its stages: list), Morris's μ* recovered on
a function with known effects, and the verdicts of a published number against an envelope."""

import dataclasses
import hashlib
import math

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from selfsense import stages
from selfsense.envelope.design import (
    MANIFEST_SHA,
    Design,
    check_chapters,
    check_member_manifests,
    envelope,
    held_unknowns,
    member_manifest,
    member_roles,
    members_asked,
    physical,
    sampling_plan,
    varied_unknowns,
    write_member_manifest,
)
from selfsense.envelope.render import combined_envelope, envelope_markdown, envelope_rows_markdown
from selfsense.envelope.unknowns import Unknown, load_unknowns
from selfsense.envelope.verdicts import (
    COLUMNS,
    MEMBER,
    NOMINAL_COLUMNS,
    Target,
    edge_counts,
    envelope_counts,
    envelope_result,
    envelope_scorecard,
    envelope_summary,
    judge,
    judge_envelope,
    member_values,
    morris_screening,
    nominal_outside,
    on_the_edge,
    rejudge,
    row_key,
)
from selfsense.io.manifest import (
    ManifestError,
    catalogue,
    load_config,
    load_dataset,
    validate_document,
)
from selfsense.io.provenance import write_table
from selfsense.scorecard.registry import Band, Entry, Tolerance

from ..helpers import ROOT


def unknown(uid, low=0.0, high=1.0, kind="uniform", nominal=None, group=None, **kw):
    nominal = low if nominal is None else nominal
    group = group or uid.upper()
    path = (f"twin.x.{uid}",)
    return Unknown(uid, "pi_p885", group, path, nominal, low, high, kind, "1", (), "s", **kw)


def design(groups, method="morris", members=8, levels=4, seed=1, spread=0):
    return Design(
        "pi_p885", members, method, seed, levels, groups, ["ripple"], "pi_p885", spread=spread
    )


@pytest.fixture(scope="module")
def shipped():
    config = load_config(ROOT / "config.yaml")
    manifests = {d: load_dataset(ROOT / "raw", d) for d in config["datasets"]}
    unknowns = load_unknowns(ROOT / "workflow" / "unknowns.yaml")
    return config, manifests, unknowns


# --- draws ----------------------------------------------------------------------------------------


# no deadline: the first draw of a normal imports scipy.stats (selfsense.envelope.design.physical)
@settings(deadline=None)
@given(st.floats(0.0, 1.0))
def test_quantiles_map_into_each_range(u):
    for item in (
        unknown("a", 2.0, 5.0),
        unknown("b", 0.01, 0.2, "loguniform"),
        unknown("c", 12, 16, "integer"),
        unknown("d", -1.0, 3.0, "normal", nominal=0.0, mean=0.0, sd=1.0),
    ):
        value = float(physical(np.array([u]), item)[0])
        assert item.low <= value <= item.high
        if item.kind == "integer":
            assert value.is_integer()


def test_quantiles_analytic():
    assert physical(np.array([0.5]), unknown("a", 2.0, 6.0))[0] == pytest.approx(4.0)
    # loguniform: the median is the geometric mean
    assert physical(np.array([0.5]), unknown("b", 0.01, 1.0, "loguniform"))[0] == pytest.approx(0.1)
    # integers 12..16: five equally likely values, u in [0.2, 0.4) is the second
    assert list(physical(np.array([0.0, 0.25, 0.99, 1.0]), unknown("c", 12, 16, "integer"))) == [
        12,
        13,
        16,
        16,
    ]
    # a normal truncated symmetrically: the median is the mean
    item = unknown("d", -2.0, 2.0, "normal", nominal=0.0, mean=0.0, sd=1.0)
    assert physical(np.array([0.5]), item)[0] == pytest.approx(0.0, abs=1e-12)


def test_morris_steps_move_one_group_at_a_time():
    group_of = {"a": "g1", "b": "g1", "c": "g2", "d": "g3", "e": "g3"}
    items = [unknown(i, group=group_of[i]) for i in "abcde"]
    plan, unit = sampling_plan(items, design(["g1", "g2", "g3"], members=8))
    assert len(plan) == 8 and list(plan.index[:2]) == ["pi_p885~01", "pi_p885~02"]
    for t in range(2):  # two trajectories of 4 points: each step changes exactly one group
        rows = unit.iloc[4 * t : 4 * t + 4].to_numpy()
        moved = [
            {group_of[c] for c in np.array(list("abcde"))[rows[k + 1] != rows[k]]} for k in range(3)
        ]
        assert all(len(m) == 1 for m in moved)
        assert set().union(*moved) == {"g1", "g2", "g3"}


def test_latin_hypercube_fills_every_stratum():
    items = [unknown(i) for i in "abc"]
    _, unit = sampling_plan(items, design(["A", "B", "C"], "latin", members=7))
    for column in unit:
        assert sorted(np.floor(unit[column] * 7).astype(int)) == list(range(7))


def test_spread_members_follow_the_trajectories_and_fill_every_stratum():
    group_of = {"a": "g1", "b": "g1", "c": "g2"}
    items = [unknown(i, group=group_of[i]) for i in "abc"]
    the_design = design(["g1", "g2"], members=6, spread=5)
    plan, unit = sampling_plan(items, the_design)
    assert len(plan) == 11 and plan.index[-1] == "pi_p885~11"
    screened, spread = member_roles(the_design, list(unit.index))
    assert screened == list(unit.index[:6]) and spread == list(unit.index[6:])
    alone, _ = sampling_plan(items, design(["g1", "g2"], members=6))
    pd.testing.assert_frame_equal(unit.iloc[:6], alone)  # the trajectories are unchanged
    for column in unit:  # the Latin hypercube's members: one in each fifth of every range
        assert sorted(np.floor(unit[column].iloc[6:] * 5).astype(int)) == list(range(5))
    # a design without spread: every member does both; a Latin hypercube screens none
    assert member_roles(design(["g1"]), ["m1", "m2"]) == (["m1", "m2"], ["m1", "m2"])
    assert member_roles(design(["g1"], "latin", spread=3), ["m1"]) == ([], ["m1"])


def test_percentiles_come_from_the_spread_members_and_drivers_from_the_trajectories():
    """Morris's grid holds a row's extremes (0 and 10 at its range's ends); the Latin hypercube's
    members, between, alone make the envelope, and the nominal lies inside it."""
    items = [unknown("a", group="A")]
    the_design = design(["A"], members=4, spread=4)
    _, unit = sampling_plan(items, the_design)
    y = 10 * unit["a"]
    nominal = card([("T", "y", 5.0, 5.0)])
    members = {m: card([("T", "y", 5.0, v)]) for m, v in y.items()}
    out, sensitivity, _ = judge_envelope(nominal, members, unit, items, the_design, [])
    spread_values = y.iloc[4:].to_numpy()
    assert out.loc[0, "members"] == 4
    assert out.loc[0, "p2.5"] == pytest.approx(np.percentile(spread_values, 2.5))
    assert out.loc[0, "p97.5"] == pytest.approx(np.percentile(spread_values, 97.5))
    assert sensitivity.loc[0, "mu_star"] == pytest.approx(10.0)  # per unit of a's range
    summary = envelope_summary(out, the_design, [], len(items), 0, "0" * 64, 8)
    assert "8 members (Morris, 2 trajectories of 1 groups, the drivers; a Latin" in summary
    assert "lies outside its envelope in 0 of the 1 findings" in summary
    low_nominal = card([("T", "y", 5.0, -1.0)])
    out, _, _ = judge_envelope(low_nominal, members, unit, items, the_design, [])
    assert len(nominal_outside(out)) == 1


def test_too_few_members_for_two_trajectories():
    with pytest.raises(ManifestError, match=r"envelope.members: 5 members .* at least 8"):
        sampling_plan(
            [unknown(i) for i in "abc"], design({"a": ["a"], "b": ["b"], "c": ["c"]}, members=5)
        )


def test_groups_vary_what_can_vary(shipped):
    _, _, unknowns = shipped
    varied = varied_unknowns(unknowns, design(["creep", "noise realisation"]))
    assert [u.id for u in varied] == [
        "creep_c_fast",
        "creep_c_slow",
        "creep_tau_fast",
        "creep_tau_slow",
        "seed_pi_p885",
    ]
    held = {u.id for u in held_unknowns(unknowns, design(["creep"]))}
    assert "adc_bits" in held and "bench_zeta" in held and "creep_c_fast" not in held
    assert "bender_capacitance" not in held  # another dataset's
    # a value the twin's code fixes (model:) is held, and a group of nothing else cannot vary
    fixed = dataclasses.replace(
        unknown("in_code", group="code"), paths=("model:stack.in_code",), where="bench.py"
    )
    chosen = varied_unknowns([*unknowns, fixed], design(["creep", "noise realisation"]))
    assert chosen == varied
    assert "in_code" in {u.id for u in held_unknowns([*unknowns, fixed], design(["creep"]))}
    for groups in (["no such group"], ["code"], ["bender creep"]):  # none, model:, other
        with pytest.raises(ManifestError, match="is no group of pi_p885's unknowns that can vary"):
            varied_unknowns([*unknowns, fixed], design(groups))


# --- members --------------------------------------------------------------------------------------


def test_member_manifest_sets_files_and_protocols(shipped):
    config, manifests, unknowns = shipped
    chosen = {u.id: u for u in unknowns}
    varied = [chosen[i] for i in ("bench_zeta", "creep_c_slow", "p1_level_b", "seed_pi_p885")]
    values = {"bench_zeta": 0.1, "creep_c_slow": 1.5e-7, "p1_level_b": 6.0, "seed_pi_p885": 7.0}
    base = manifests["pi_p885"]
    member = member_manifest(base, varied, values, "pi_p885~03", ["ripple", "ch3"])
    validate_document(member, "dataset.schema.yaml", "member")
    assert member["twin"]["stack"]["zeta"] == 0.1
    assert member["twin"]["creep"]["C"][1] == 1.5e-7
    assert member["seed"] == 7 and isinstance(member["seed"], int)
    assert base["twin"]["stack"]["zeta"] != 0.1  # the nominal manifest is not touched
    experiments = catalogue(member, "thesis")
    for run in ("ch6_p1_open", "ch6_p1_closed"):
        assert experiments[run].protocol["segments"][1]["hi"] == 6.0
    assert catalogue(base, "thesis")["ch6_p1_open"].protocol["segments"][1]["hi"] == 5
    plan = stages.plan_stages(member, experiments)
    assert plan.running() == ["ripple", "ch3"]
    assert "stages: list" in plan.lacks["identify"][0]


def test_member_manifest_writes_a_variant_key_the_manifest_leaves_out(shipped):
    """A twin variant's key (off by default, absent from the shipped manifest) is written with its
    section, so a design that varies the variant's group switches its term on."""
    _, manifests, unknowns = shipped
    (support,) = [u for u in unknowns if u.id == "support_compliance"]
    base = manifests["pi_p885"]
    member = member_manifest(base, [support], {"support_compliance": 2e-7}, "pi_p885~04", [])
    validate_document(member, "dataset.schema.yaml", "member")
    assert member["twin"]["support"] == {"compliance": 2e-7}
    assert "support" not in base["twin"]


def test_protocol_override_must_name_a_number(shipped):
    _, manifests, _ = shipped
    base = manifests["pi_p885"]
    for key, said in (
        ("ch6:experiments.ch6_p1_open.segments.0.nope", "holds no number there"),
        ("ch6:experiments.nope.segments.0.hi", "has no such key"),
        ("ch9:experiments.x", "not <protocol>:<dotted key> of a protocol the dataset runs"),
    ):
        with pytest.raises(ManifestError, match=said):
            catalogue(base | {"protocol_overrides": {key: 1.0}}, "thesis", "m.yaml")


def test_shipped_envelope_is_drawn_and_valid(shipped):
    config, manifests, unknowns = shipped
    the_design = Design.from_config(config["envelope"])
    drawn = envelope(the_design, manifests, unknowns)
    groups = len(config["envelope"]["groups"])
    morris = config["envelope"]["members"] // (groups + 1) * (groups + 1)
    assert len(drawn.manifests) == morris + config["envelope"]["spread"]
    assert not {u.id for u in drawn.varied} & {u.id for u in drawn.held}
    for u in drawn.varied:  # every draw inside its declared range
        assert drawn.plan[u.id].between(u.low, u.high).all()
    again = envelope(the_design, manifests, unknowns)  # the plan is the seed's
    pd.testing.assert_frame_equal(drawn.plan, again.plan)


@pytest.mark.parametrize(
    ("changes", "key", "said"),
    [
        ({"name": "ch7\n"}, "envelope.name", "'ch7\\n' is not a name"),
        ({"name": "a" * 254}, "envelope.name", "of at most 64 characters"),
        ({"dataset": "pi_p885\n"}, "envelope.dataset", "is not a name"),
        ({"members": 400, "spread": 200}, "envelope.spread", "more than the 500 one design"),
    ],
)
def test_the_design_refuses_names_and_sizes_in_one_line(shipped, changes, key, said):
    config = shipped[0]
    with pytest.raises(ManifestError) as err:
        Design.from_config(config["envelope"] | changes, "c.yaml")
    assert str(err.value).startswith(f"c.yaml: key {key}: ") and "\n" not in str(err.value)
    assert said in str(err.value)
    assert err.value.key == key


def test_the_config_schema_bounds_the_envelope(shipped):
    config = shipped[0]
    for changes, said in (
        ({"members": 10_000}, "envelope.members: 10000 is greater than the maximum of 500"),
        ({"spread": 501}, "envelope.spread: 501 is greater than the maximum of 500"),
        ({"name": "a" * 254}, "envelope.name: "),
    ):
        with pytest.raises(ManifestError, match=said):
            validate_document(config | {"envelope": config["envelope"] | changes},
                              "config.schema.yaml", "c.yaml")  # fmt: skip


@pytest.mark.parametrize(
    ("targets", "asked"),
    [
        ((), False),  # the default run: rule all
        (("all", "results/pi_p885/scorecard.csv", "report"), False),
        (("envelope",), True),
        (("results/envelope/pi_p885_ch7/scorecard.csv",), True),
        (("results/pi_p885~07/scorecard.csv",), True),
        (("TargetSpec(rulename='simulate', wildcards_dict={'dataset': 'pi_p885~07'})",), True),
    ],
)
def test_members_are_drawn_only_for_a_target_that_needs_them(targets, asked):
    assert members_asked(targets) is asked


def test_a_chapter_no_emergent_row_has_is_refused():
    check_chapters(Design(**{**design(["A"]).__dict__, "chapters": ["7"]}), ["5", "7"])
    with pytest.raises(
        ManifestError, match=r"key envelope.chapters: '99' is no chapter .*\(5, 7\)"
    ):
        check_chapters(Design(**{**design(["A"]).__dict__, "chapters": ["99"]}), ["5", "7", "7"])


def test_a_member_manifest_edited_by_hand_is_refused(shipped, tmp_path):
    """Members written from the plan pass; one edited by hand is refused naming its file; one an
    earlier plan recorded (a draw the workflow will write again) passes."""
    _, manifests, unknowns = shipped
    drawn = envelope(design(["creep"], "latin", members=2), manifests, unknowns)
    assert drawn.plan[MANIFEST_SHA].str.fullmatch("[0-9a-f]{64}").all()
    plan = tmp_path / "plan.csv"
    drawn.plan.reset_index().to_csv(plan, index=False)
    for name, manifest in drawn.manifests.items():
        write_member_manifest(manifest, tmp_path / name / "dataset.yaml")
    check_member_manifests(drawn, tmp_path, plan)
    first = tmp_path / "pi_p885~01" / "dataset.yaml"
    first.write_text(first.read_text().replace("stages:", "# edited\nstages:"))
    with pytest.raises(ManifestError, match=r"pi_p885~01/dataset.yaml: differs from its draw"):
        check_member_manifests(drawn, tmp_path, plan)
    recorded = pd.read_csv(plan)
    recorded.loc[0, MANIFEST_SHA] = hashlib.sha256(first.read_bytes()).hexdigest()
    recorded.to_csv(plan, index=False)  # the earlier plan wrote it so: rewritten, not refused
    check_member_manifests(drawn, tmp_path, plan)


#: Chapter 7's own design (docs/envelope.md): only what its rows depend on varies, the noise its
#: fits and errors are made of included, and its thermal stage needs the observer and identify
#: stages (stages.py)
CH7 = {
    "name": "pi_p885_ch7",
    "chapters": ["7"],
    "members": 14,
    "spread": 0,
    "groups": [
        "thermal",
        "thermometer",
        "chapter 7 records",
        "instrument noise",
        "offsets and drifts",
        "noise realisation",
    ],
    "stages": ["ripple", "identify", "gamma", "observer", "thermal"],
}
#: the groups only Chapter 7's rows depend on: the Chapters 3–6 design holds them
CH7_ONLY = {"thermal", "thermometer", "chapter 7 records"}


def test_a_named_design_keeps_its_members_apart(shipped):
    config, manifests, unknowns = shipped
    section = config["envelope"] | CH7
    drawn = envelope(Design.from_config(section), manifests, unknowns)
    assert list(drawn.manifests) == [f"pi_p885_ch7~{k:02d}" for k in range(1, 15)]  # 2 × (6 + 1)
    assert {u.group for u in drawn.varied} == set(CH7["groups"])
    chapters_3_6 = envelope(Design.from_config(config["envelope"]), manifests, unknowns).varied
    assert not {u.group for u in chapters_3_6} & CH7_ONLY
    member = drawn.manifests["pi_p885_ch7~01"]
    plan = stages.plan_stages(member, catalogue(member, "thesis"))
    assert plan.running() == CH7["stages"]
    assert Design.from_config(section).chapters == ["7"]


# --- Morris's screening ---------------------------------------------------------------------------


def test_morris_recovers_known_effects():
    """y = 3a + b² + 0·c: μ* of a is 3 per unit range, of c 0; b's σ > 0 (non-linear)."""
    items = [unknown(i) for i in "abc"]
    the_design = design(["A", "B", "C"], members=40, levels=4)
    _, unit = sampling_plan(items, the_design)
    outputs = pd.DataFrame({"y": 3 * unit["a"] + unit["b"] ** 2}, index=unit.index)
    screened = morris_screening(items, the_design, unit, outputs).set_index("factor")
    assert screened.loc["A", "mu_star"] == pytest.approx(3.0)
    assert screened.loc["A", "sigma"] == pytest.approx(0.0, abs=1e-9)
    assert screened.loc["C", "mu_star"] == pytest.approx(0.0, abs=1e-12)
    assert 0 < screened.loc["B", "mu_star"] < 2 and screened.loc["B", "sigma"] > 0


def test_screening_skips_an_output_a_member_lacks():
    items = [unknown(i) for i in "ab"]
    the_design = design(["A", "B"], members=6)
    _, unit = sampling_plan(items, the_design)
    y = unit["a"].to_numpy().copy()
    y[2] = np.nan
    screened = morris_screening(items, the_design, unit, pd.DataFrame({"y": y}, index=unit.index))
    assert screened.empty


# --- verdicts -------------------------------------------------------------------------------------


def value(published, half=0.0):
    """The target of a value row without a band: its printed value ± ``half``."""
    return Target(published - half, published + half, math.nan)


def test_judge_analytic():
    assert judge(0.5, 1.5, value(1.0)).verdict == "consistent"
    outside = judge(0.5, 1.5, value(2.0))
    assert outside.verdict == "inconsistent" and outside.distance == pytest.approx(0.5)
    # the printed precision widens the published value: 1.6 ± 0.15 reaches 1.5, ± 0.04 misses it
    assert judge(0.5, 1.5, value(1.6, 0.15)).verdict == "consistent"
    assert judge(0.5, 1.5, value(1.6, 0.04)).distance == pytest.approx(0.06)
    # a bound is met when some of the envelope meets it
    assert judge(0.9, 5.0, Target(-math.inf, 1.0, math.nan)).verdict == "consistent"
    assert judge(1.2, 5.0, Target(-math.inf, 1.0, math.nan)).distance == pytest.approx(0.2 / 3.8)
    assert judge(0.1, 0.5, Target(1.0, math.inf, math.nan)).distance == pytest.approx(0.5 / 0.4)
    assert math.isinf(judge(1.0, 1.0, value(2.0)).distance)
    # wider than the row's band: uninformative; as wide or narrower: informative
    assert judge(0.5, 1.5, Target(1.0, 1.0, 0.9)).verdict == "consistent (uninformative)"
    assert judge(0.5, 1.5, Target(1.0, 1.0, 1.0)).verdict == "consistent"


@pytest.mark.parametrize(
    ("aim", "edge"),
    [
        (value(11.5), False),  # mid-envelope
        (value(2.0), False),  # inside by more than a gap: 0.575 + 1 < 2
        (value(1.2), True),  # inside by less than a gap: the edge moved in passes it
        (value(0.0), True),  # outside by less than a gap: the edge moved out reaches it
        (value(-5.0), False),  # outside by more than a gap
        (value(23.0), True),  # the upper edge, 22.425, the same way
        (Target(-math.inf, 0.3, math.nan), True),  # "< 0.3": met once the lower edge moves out
        (Target(0.3, math.inf, math.nan), False),  # "> 0.3": met by the upper edge, far away
        (Target(11.0, 12.0, 1.0), False),  # uninformative or not is no change of the verdict
    ],
)
def test_on_the_edge_analytic(aim, edge):
    # 24 members 0, 1, …, 23: the 2.5 and 97.5 percentiles are 0.575 and 22.425, each between
    # the outermost two members on its side, a gap of 1
    assert on_the_edge(np.arange(24.0), aim) is edge


def test_on_the_edge_moves_by_the_gap_its_percentile_lies_in():
    # one far member: the lower edge (-100 + 0.575 · 100 = -42.5) rests on it, a gap of 100
    lone = np.r_[-100.0, np.arange(23.0)]
    assert on_the_edge(lone, value(-60.0)) and on_the_edge(lone, value(-30.0))
    assert not on_the_edge(lone, value(-150.0))
    # 81 members: the 2.5 percentile is the third member, 2, a gap of 1 from the fourth; the far
    # first member no longer sets the gap (with it, 0.5 would be on the edge)
    many = np.r_[-100.0, np.arange(1.0, 81.0)]
    assert np.percentile(many, 2.5) == pytest.approx(2.0)
    assert on_the_edge(many, value(2.5)) and not on_the_edge(many, value(0.5))
    # the printed precision counts as in the verdict: 1.6 ± 0.5 is 0.9 from the edge moved in
    assert not on_the_edge(np.arange(24.0), value(1.6, 0.5))


def entry(quantity, tolerance, bound=None, twin=None, source="T", published=1.0, printed=None):
    """A registry entry of an emergent row of source ``source`` (chapter 6, µm)."""
    return Entry(
        section="published",
        kind="emergent",
        chapter="6",
        source=source,
        model="stack",
        quantity=quantity,
        unit="µm",
        published=published,
        band=Band("a band", "why", tolerance, bound),
        bound=bound,
        printed=printed,
        twin=twin,
    )


def card(rows):
    return pd.DataFrame(
        [
            {
                "kind": "emergent",
                "chapter": "6",
                "source": s,
                "quantity": q,
                "unit": "µm",
                "published": p,
                "reproduced": r,
                "verdict": "within band",
            }
            for s, q, p, r in rows
        ]
    )


def test_envelope_scorecard_verdicts():
    nominal = card(
        [
            ("T", "narrow", 1.0, 1.0),
            ("T", "wide", 1.0, 1.0),
            ("T", "far", 10.0, 1.0),
            ("T", "few", 1.0, 1.0),
        ]
    )
    members = {}
    for k, (narrow, wide, far) in enumerate(
        [(0.9, 0.2, 1.0), (1.0, 1.0, 1.1), (1.1, 3.0, 0.9), (1.05, 2.0, 1.0)]
    ):
        member = card(
            [("T", "narrow", 1.0, narrow), ("T", "wide", 1.0, wide), ("T", "far", 10.0, far)]
        )
        if k == 0:
            member = pd.concat([member, card([("T", "few", 1.0, 1.0)])])
        members[f"m~{k + 1:02d}"] = member
    keys = [row_key("T", q) for q in ("narrow", "wide", "far", "few")]
    values = member_values(members, keys)
    assert values[row_key("T", "few")].notna().sum() == 1
    bands = [entry(q, Tolerance(rel=25)) for q in ("narrow", "wide", "far", "few")]
    out = envelope_scorecard(nominal, values, pd.DataFrame(), bands).set_index("quantity")
    assert out.loc["narrow", "envelope verdict"] == "consistent"
    assert out.loc["narrow", "p50"] == pytest.approx(np.percentile([0.9, 1.0, 1.1, 1.05], 50))
    assert out.loc["wide", "envelope verdict"] == "consistent (uninformative)"
    assert out.loc["far", "envelope verdict"] == "inconsistent"
    assert out.loc["few", "envelope verdict"] == "no envelope"
    assert envelope_counts(out.reset_index()) == {
        "consistent": 1,
        "consistent (uninformative)": 1,
        "inconsistent": 1,
        "no verdict": 0,
        "no envelope": 1,
        "findings": 4,
        "rows": 4,
    }
    # "far" is 9 envelope widths out, "narrow" well inside; "wide" (0.2 … 3.0, published 1.0)
    # too; "few" has no envelope to be on the edge of
    assert out["on the edge"].tolist()[:3] == [False, False, False]
    assert pd.isna(out.loc["few", "on the edge"])
    summary = envelope_summary(out.reset_index(), design(["X"]), [], 0, 0, "0" * 64, 4)
    assert "the 4 members behind the percentiles gave a value for:\n\n- T, few: 1 of 4\n" in summary
    assert "On the edge" in summary and ": 0 of 3 findings (consistent 0," in summary


def test_a_row_on_the_edge_is_marked_in_the_lists(tmp_path):
    nominal = card([("T", "edge", 1.1, 1.0), ("T", "out", 90.0, 1.0)])
    members = {
        f"m~{k:02d}": card([("T", "edge", 1.1, 1.1 + 0.1 * k), ("T", "out", 90.0, 1.0 + k)])
        for k in range(24)
    }
    values = member_values(members, [row_key("T", q) for q in ("edge", "out")])
    out = envelope_scorecard(nominal, values, pd.DataFrame(), [])
    assert out["envelope verdict"].tolist() == ["inconsistent", "inconsistent"]
    assert out["on the edge"].tolist() == [True, False]
    summary = envelope_summary(out, design(["X"]), [], 0, 0, "0" * 64, 24)
    assert (
        ": 1 of 2 findings (consistent 0, consistent (uninformative) 0, inconsistent 1)" in summary
    )
    assert "widths, on the edge; no screening)" in summary
    # the docs' list reads the card back from its CSV
    out.to_csv(tmp_path / "card.csv", index=False)
    listed = envelope_rows_markdown(pd.read_csv(tmp_path / "card.csv")).splitlines()
    assert listed[0].endswith("; 1 of them on the edge, where one member's draw decides.")
    assert [line.endswith("widths, on the edge); driven by –") for line in listed[3:]] == [
        True,
        False,
    ]


def judged_rows(rows, entries, members=24):
    """The envelope scorecard of rows (quantity, published, members' values from low to high,
    evenly), each with its registry entry."""
    nominal = card([("T", q, pub, pub) for q, pub, _, _ in rows])
    cards = {
        f"m~{k:02d}": card(
            [("T", q, pub, lo + (hi - lo) * k / (members - 1)) for q, pub, lo, hi in rows]
        )
        for k in range(members)
    }
    values = member_values(cards, [row_key("T", q) for q, *_ in rows])
    return envelope_scorecard(nominal, values, pd.DataFrame(), entries).set_index("quantity")


def test_a_bound_is_judged_against_its_registry_band():
    """The fitted curve "≤ 1.5 µm" (published 0, band abs 1.5 upper) is met by an envelope from
    1.2 µm, missed by one from 1.6 µm (half an envelope width beyond); a p "≥ published − 0.28"
    (0.33, a band from 0.05) is met by members up to 0.243; a bound is never uninformative."""
    curve = Tolerance(abs=1.5)
    entries = [
        entry("curve met", curve, "upper", published=0.0),
        entry("curve missed", curve, "upper", published=0.0),
        entry("p", Tolerance(abs=0.28), "lower", published=0.33),
        entry("wide bound", Tolerance(abs=0.0), "upper"),
    ]
    rows = [
        ("curve met", 0.0, 1.2, 4.0),
        ("curve missed", 0.0, 1.6, 1.8),
        ("p", 0.33, 0.0, 0.243),
        ("wide bound", 1.0, -10.0, 300.0),
    ]
    out = judged_rows(rows, entries)
    assert out.loc["curve met", "envelope verdict"] == "consistent"
    assert out.loc["curve missed", "envelope verdict"] == "inconsistent"
    low, high = out.loc["curve missed", ["p2.5", "p97.5"]]
    assert out.loc["curve missed", "distance [widths]"] == pytest.approx((low - 1.5) / (high - low))
    assert out.loc["p", "envelope verdict"] == "consistent"
    assert out.loc["wide bound", "envelope verdict"] == "consistent"
    assert out["width / band"].isna().all()  # a bound has no band width to be wider than


def test_a_row_the_registry_gives_no_verdict_gets_none():
    entries = [entry("b0", None), entry("R²", Tolerance(rel=1))]
    out = judged_rows([("b0", 1.0, 5.0, 9.0), ("R²", 1.0, 0.99, 1.01)], entries)
    assert out.loc["b0", "envelope verdict"] == "no verdict"
    assert out.loc["b0", "p50"] == pytest.approx(7.0)  # its envelope shown for information
    assert out.loc["b0", "on the edge"] == False  # noqa: E712 (a verdict it does not have)
    counts = envelope_counts(out.reset_index())
    assert counts["no verdict"] == 1 and counts["inconsistent"] == 0


def test_uninformative_is_relative_to_the_rows_own_band():
    """Envelope 0.7–1.5 around 1.0 (a half-width of 40 %) inside a position-error band 0.625–1.6
    says as much as the band: informative; 0.95–1.05 (5 %) against a band of half a printed
    digit, 0.995–1.005, is ten times wider than it: uninformative."""
    entries = [
        entry("position", Tolerance(abs=0.6, scale="log")),
        entry("digit", Tolerance(digit=0.5), printed="1.00"),
    ]
    # 24 members evenly: p2.5 and p97.5 lie 0.0225 · span inside the given ends
    out = judged_rows([("position", 1.0, 0.68, 1.52), ("digit", 1.0, 0.948, 1.052)], entries)
    assert out.loc["position", "envelope verdict"] == "consistent"
    assert out.loc["position", "width / band"] < 1 < out.loc["position", "half-width [%]"] / 25
    assert out.loc["digit", "envelope verdict"] == "consistent (uninformative)"
    assert out.loc["digit", "width / band"] == pytest.approx(10.0, rel=0.05)


def test_algebraic_twins_are_one_finding(tmp_path):
    """A % of stroke row is counted with its µm row, by the µm row's verdict; a twin whose verdict
    differs is named in the summary; the docs' list and the README's table count findings."""
    entries = [
        entry("error", Tolerance(rel=10)),
        entry("error, % of stroke", Tolerance(rel=10), twin="error"),
        entry("other", Tolerance(rel=10)),
    ]
    rows = [("error", 1.0, 2.0, 3.0), ("error, % of stroke", 3.0, 2.9, 3.1), ("other", 1.0, 5, 6)]
    out = judged_rows(rows, entries).reset_index()
    assert list(out["twin of"]) == ["", "error", ""]
    counts = envelope_counts(out)
    assert counts["inconsistent"] == 2 and counts["consistent"] == 0
    assert counts["findings"] == 2 and counts["rows"] == 3
    summary = envelope_summary(out, design(["X"]), [], 0, 0, "0" * 64, 24)
    assert "Emergent rows: 3, findings: 2" in summary
    assert "- T, error, % of stroke: consistent; error: inconsistent" in summary
    out.to_csv(tmp_path / "card.csv", index=False)  # the twin column read back from its CSV
    back = pd.read_csv(tmp_path / "card.csv")
    assert envelope_rows_markdown(back).startswith("2 findings are inconsistent")
    record = {"code": "abc", "members": ["m"] * 24, "campaign": "thesis"}
    table = envelope_markdown([(back, design(["X"]), record)]).splitlines()
    assert table[-1].startswith("| **total** | 3 | 2 | 0 | 0 | 2 | 0 | 0 |")


def test_remade_verdicts_from_the_cards_percentiles():
    """A card judged before the registry's bands were used: its bound row on the printed value,
    its coefficient judged, its twin counted; remade from its own percentiles, the bound meets
    its band (its edge unknown without the members' values), the coefficient has no verdict, the
    value row keeps its verdict and edge."""
    entries = [
        entry("curve", Tolerance(abs=1.5), "upper", published=0.0),
        entry("b0", None),
        entry("error", Tolerance(rel=10), printed="1.00"),
        entry("error, % of stroke", Tolerance(rel=10), twin="error"),
    ]
    old = pd.DataFrame(
        {
            "chapter": "5",
            "source": "T",
            "quantity": ["curve", "b0", "error", "error, % of stroke"],
            "unit": "µm",
            "published": [0.0, 1.0, 1.0, 3.0],
            "reproduced": [2.4, 2.0, 1.0, 3.0],
            "verdict": "out of band",
            "members": 24,
            "p2.5": [1.2, 0.5, 1.1, 3.3],
            "p50": [2.0, 1.0, 1.5, 4.5],
            "p97.5": [4.0, 1.5, 2.0, 6.0],
            "half-width [%]": [np.inf, 50.0, 45.0, 45.0],
            "envelope verdict": ["inconsistent", "consistent", "inconsistent", "inconsistent"],
            "distance [widths]": [0.3, np.nan, 0.1, 0.1],
            "on the edge": [True, False, True, False],
            "driven by": "",
        }
    )
    remade = rejudge(old, entries)
    assert list(remade.columns) == NOMINAL_COLUMNS + COLUMNS
    remade = remade.set_index("quantity")
    assert remade.loc["curve", "envelope verdict"] == "consistent"
    assert pd.isna(remade.loc["curve", "on the edge"])
    assert remade.loc["b0", "envelope verdict"] == "no verdict"
    assert remade.loc["b0", "on the edge"] == False  # noqa: E712
    assert remade.loc["error", "envelope verdict"] == "inconsistent"
    assert remade.loc["error", "on the edge"] == True  # noqa: E712
    assert remade.loc["error, % of stroke", "twin of"] == "error"
    assert envelope_counts(remade.reset_index())["findings"] == 3
    assert edge_counts(remade.reset_index()).endswith(
        "of 2 findings (consistent 0, "
        "consistent (uninformative) 0, inconsistent 1); not known for 1"
    )


def test_the_ensembles_tables_remake_the_verdicts_without_the_members(tmp_path):
    """Five members' synthetic scorecards (two emergent rows, one a member lacks, and a
    calibration signature): the envelope keeps members × rows and members × signatures; read back
    from their CSVs they give the same envelope scorecard."""
    items = [unknown("a", group="A")]
    the_design = design(["A"], method="latin", members=5)
    _, unit = sampling_plan(items, the_design)
    signature = card([("S", "loop width", 5.0, 5.0)]).assign(kind="calibration")
    nominal = pd.concat([card([("T", "x", 1.0, 1.0), ("T", "y", 2.0, 2.0)]), signature])
    members = {}
    for k, m in enumerate(unit.index):
        rows = [("T", "x", 1.0, 0.8 + 0.1 * k)] + ([("T", "y", 2.0, 2.0 + k)] if k else [])
        members[m] = pd.concat([card(rows), signature.assign(reproduced=4.0 + k)])
    entries = [entry("x", Tolerance(rel=10)), entry("y", Tolerance(rel=10), published=2.0)]
    result = envelope_result(the_design, nominal, members, unit, items, entries, "0" * 64)
    assert list(result.values.index) == list(unit.index)
    assert list(result.values.columns) == [row_key("T", "x"), row_key("T", "y")]
    assert np.isnan(result.values.iloc[0, 1]) and result.values.iloc[4, 1] == 6.0
    assert list(result.signatures.columns) == [row_key("S", "loop width")]
    assert list(result.signatures.iloc[:, 0]) == [4.0, 5.0, 6.0, 7.0, 8.0]
    for name, table in (("values", result.values), ("signatures", result.signatures)):
        write_table(table.reset_index(), tmp_path / f"{name}.csv")
    values = pd.read_csv(tmp_path / "values.csv", index_col=MEMBER)
    assert pd.read_csv(tmp_path / "signatures.csv", index_col=MEMBER).shape == (5, 1)
    again = envelope_scorecard(nominal, values, pd.DataFrame(), entries)
    pd.testing.assert_frame_equal(again, result.card)


def test_a_design_judges_its_own_chapters_only():
    # chapter 6's rows vary, chapter 7's are held at their nominal: a design of chapter 6 judges
    # its own rows alone
    nominal = pd.concat(
        [card([("T", "a", 1.0, 1.0)]), card([("U", "b", 1.0, 1.0)]).assign(chapter="7")]
    )
    members = {
        f"m~{k:02d}": pd.concat(
            [card([("T", "a", 1.0, v)]), card([("U", "b", 1.0, 1.0)]).assign(chapter="7")]
        )
        for k, v in enumerate((0.9, 1.0, 1.1), 1)
    }
    unit = pd.DataFrame({"x": [0.0, 0.5, 1.0]}, index=list(members))
    every = design(["X"], method="latin", members=3)
    own = Design(**{**every.__dict__, "chapters": ["6"]})
    judged = [judge_envelope(nominal, members, unit, [], d, [])[0] for d in (every, own)]
    assert list(judged[0]["quantity"]) == ["a", "b"] and list(judged[1]["quantity"]) == ["a"]


def test_a_second_design_fills_the_rows_the_first_has_no_envelope_for():
    def judged(rows):
        return pd.DataFrame(
            rows, columns=["chapter", "source", "quantity", "p50", "envelope verdict"]
        )

    first = judged(
        [
            ("6", "T", "a", 1.0, "consistent"),
            ("7", "U", "b", np.nan, "no envelope"),
            ("7", "U", "c", np.nan, "no envelope"),
        ]
    )
    chapter_7 = judged([("7", "U", "c", 2.0, "inconsistent"), ("7", "U", "b", 3.0, "consistent")])
    both = combined_envelope([first, chapter_7])
    assert list(both["quantity"]) == ["a", "b", "c"] and list(both.columns) == list(first.columns)
    assert list(both["envelope verdict"]) == ["consistent", "consistent", "inconsistent"]
    assert list(both["p50"]) == [1.0, 3.0, 2.0]
    with pytest.raises(ValueError, match="judged by two designs.*'a'"):
        combined_envelope([first, judged([("6", "T", "a", 1.1, "inconsistent")])])
    with pytest.raises(ValueError, match="no other design.*'d'"):
        combined_envelope([first, judged([("7", "U", "d", 1.0, "consistent")])])
