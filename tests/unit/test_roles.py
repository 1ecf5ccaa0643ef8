"""Run roles (selfsense.io.roles): the catalogue declares each run's parts, a manifest maps its
own runs onto them, and the stage plan skips a stage whose roles have no run, naming them. The
end-to-end case, a lab's own names through the DAG, is tests/workflow/test_roles.py."""

from pathlib import Path

import pytest

from selfsense import stages
from selfsense.io import roles
from selfsense.io.manifest import PROTOCOLS, expand_protocols, load_dataset, load_yaml

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def stack():
    return load_dataset(ROOT / "raw", "pi_p885")


@pytest.fixture(scope="module")
def catalogue(stack):
    return expand_protocols(stack["protocols"], "thesis", PROTOCOLS)


def test_every_role_a_stage_needs_is_played_by_a_run_of_the_catalogue(catalogue):
    needed = {r for s in stages.STAGES for r in s.roles}
    assert needed <= set(roles.ROLES)
    bender = expand_protocols(["ronkanen"], "thesis", PROTOCOLS)
    assert [r for r in sorted(needed) if not roles.runs(catalogue | bender, r)] == []
    # and every declared role is read by some stage (no role nobody asks for)
    assert set(roles.ROLES) == needed


def test_a_one_run_role_on_an_entry_of_sets_is_its_first_sets(catalogue):
    assert roles.run(catalogue, "identify.force_record") == "ch4_sine_50hz_s1"
    assert roles.runs(catalogue, "identify.set")[:2] == ["ch4_sine_10hz_s1", "ch4_sine_10hz_s2"]
    assert len(roles.runs(catalogue, "identify.set")) == 20


def test_the_nominal_frequency_is_the_catalogues_not_the_campaigns(stack):
    smoke = expand_protocols(stack["protocols"], "smoke", PROTOCOLS)
    slow = roles.by_frequency(smoke, "observer.sine")
    assert slow[0.01] == "ch5_sine_0p01hz"
    # the smoke campaign runs it faster; the tables name it by the thesis's frequency
    assert smoke["ch5_sine_0p01hz"].protocol["segments"][0]["frequency"] != 0.01


def test_a_manifest_maps_its_own_runs_and_the_role_leaves_the_catalogues(catalogue):
    listed = {"my_hold": None, "slow": None, "ch4_sine_20hz_s1": catalogue["ch4_sine_20hz_s1"]}
    mapped = roles.assign_roles(
        listed | {"ch4_sine_50hz_s1": catalogue["ch4_sine_50hz_s1"]},
        catalogue,
        {"gamma.fit": "slow", "identify.force_record": "ch4_sine_20hz_s1"},
        "raw/lab/dataset.yaml",
    )
    assert roles.run(mapped, "gamma.fit") == "slow"
    # the lab's run follows the catalogue's run of the role: its protocol and nominal frequency
    assert mapped["slow"].protocol == catalogue["ch5_sine_0p1hz"].protocol
    assert mapped["slow"].nominal_hz == 0.1 and mapped["slow"].name == "slow"
    assert roles.run(mapped, "identify.force_record") == "ch4_sine_20hz_s1"
    assert "identify.force_record" not in mapped["ch4_sine_50hz_s1"].roles
    assert "identify.set" in mapped["ch4_sine_50hz_s1"].roles  # its other roles stay


def test_a_role_of_several_runs_names_the_catalogue_run_each_follows(catalogue):
    mapped = roles.assign_roles(
        {"a": None, "b": None},
        catalogue,
        {"observer.sine": {"a": "ch5_sine_10hz", "b": "ch5_sine_100hz"}},
        "m.yaml",
    )
    assert roles.by_frequency(mapped, "observer.sine") == {10.0: "a", 100.0: "b"}
    with pytest.raises(
        ValueError, match=r"^m.yaml: key roles.observer.sine.a: the catalogue has 7"
    ):
        roles.assign_roles({"a": None}, catalogue, {"observer.sine": ["a"]}, "m.yaml")


@pytest.mark.parametrize(
    ("mapping", "message"),
    [
        ({"gamma.fitt": "x"}, "m.yaml: key roles.gamma.fitt: 'gamma.fitt' is no role"),
        ({"gamma.fit": ["x", "y"]}, "m.yaml: key roles.gamma.fit: one run plays this role, 2"),
        ({"gamma.fit": "nope"}, "m.yaml: key roles.gamma.fit: 'nope' is not among the dataset"),
        ({"gamma.fit": {"x": "ch9_x"}}, "m.yaml: key roles.gamma.fit.x: 'ch9_x' is no run"),
    ],
)
def test_a_bad_mapping_is_one_line_naming_the_file_and_key(catalogue, mapping, message):
    with pytest.raises(ValueError) as err:
        roles.assign_roles({"x": None, "y": None}, catalogue, mapping, "m.yaml")
    assert str(err.value).startswith(message) and "\n" not in str(err.value)


def test_a_catalogue_role_that_is_none_is_refused_naming_the_file(tmp_path):
    doc = load_yaml(PROTOCOLS / "ch3.yaml")
    doc["experiments"]["ch3_sine_10hz"]["roles"] = ["ch3.series_11hz"]
    (tmp_path / "ch3.yaml").write_text(__import__("yaml").safe_dump(doc))
    with pytest.raises(ValueError, match=r"ch3.yaml: ch3_sine_10hz: key roles: 'ch3.series_11hz'"):
        expand_protocols(["ch3"], "thesis", tmp_path)


def test_a_stage_without_a_run_of_its_role_is_skipped_naming_the_role(stack, catalogue):
    subset = {e: x for e, x in catalogue.items() if "observer.creep" not in x.roles}
    plan = stages.plan_stages(stack, subset)
    assert not plan.runs("observer") and plan.runs("gamma")
    assert plan.lacks["observer"] == (f"role observer.creep ({roles.ROLES['observer.creep']})",)
    # and what builds on it says so, the rest runs
    assert "the observer stage" in plan.lacks["control"] and plan.runs("identify")
