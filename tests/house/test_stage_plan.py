"""The stage plan (selfsense.stages) is the one place that says which stages run for a dataset:
its rows are results/<dataset>/stages.csv, and the workflow gates its rules with it. These tests
hold the plan of the shipped datasets to its table (the rows it had before the plan was one
module, plus the Chapter 3 row), the plan of datasets that lack channels or runs, and the rules
a dry run schedules to the plan's rows."""

import copy
import re

import pytest
import yaml

from selfsense import stages
from selfsense.io.manifest import ManifestError, expand_protocols, load_dataset
from selfsense.io.roles import ROLES

from ..helpers import ROOT, SMOKE_CONFIG, copy_repo, run_snakemake

PROTOCOLS = ROOT / "workflow" / "protocols"

CHARACTERISE = ("characterise", True, "channel U and a displacement x_laser or x_disp")
RIPPLE = "ripple channels Ur, Ir with U, I, x_laser and a folding plan (daq.ripple)"
CH3 = "ripple stage and the Chapter 3 series at 10, 1 and 0.1 Hz"
IDENTIFY = "ripple stage, Chapter 4 sine sets and the static stiffness tests"
GAMMA = "ripple stage and the 0.1 Hz run Γ is fitted on"
OBSERVER = "gamma stage, the Table 5.4 sines, 10–300 Hz sines and the creep run"
SWEEP = "identify stage and the stepped-sine sweep"
CONTROL = "observer and identify stages and the profiles P1–P3, open and closed loop"
THERMAL = "observer and identify stages, the Chapter 7 runs and T_mid"
POWERLOSS = "U, I, i_cmd, x_disp channels and the Ronkanen runs"
LACKS = "; this dataset lacks: "


def lacking(*roles):
    """What a skipped stage's row says of the roles it has no run of."""
    return ", ".join(f"role {r} ({ROLES[r]})" for r in roles)


PROFILE_ROLES = [
    f"control.{p}_{c}" for p in ("p1", "p2a", "p2b", "p2c", "p2d", "p3") for c in ("open", "closed")
]
RONKANEN_ROLES = [
    "powerloss.hold",
    "powerloss.ramp",
    "powerloss.ramp_too_large",
    "powerloss.ramp_too_small",
    "powerloss.ramp_ideal",
    *(f"powerloss.{k}_{c}" for k in ("decay", "repeat", "drift") for c in ("current", "voltage")),
]

#: stages.csv of the shipped datasets, (stage, runs, needs) a row, in both campaigns
SHIPPED = {
    "pi_p885": [
        CHARACTERISE,
        ("ripple (Ch. 3)", True, RIPPLE),
        ("hysteresis and figures (Ch. 3)", True, CH3),
        ("identify (Ch. 4)", True, IDENTIFY),
        ("gamma (Ch. 5)", True, GAMMA),
        ("observer (Ch. 5)", True, OBSERVER),
        ("frequency response (Ch. 5, Fig 5.3)", True, SWEEP),
        ("control (Ch. 6)", True, CONTROL),
        ("thermal (Ch. 7)", True, THERMAL),
        (
            "powerloss (Ronkanen)",
            False,
            POWERLOSS + LACKS + lacking(*RONKANEN_ROLES) + ", channel i_cmd, channel x_disp",
        ),
    ],
    "tokin_nb40": [
        CHARACTERISE,
        (
            "ripple (Ch. 3)",
            False,
            RIPPLE + LACKS + "channel Ur, channel Ir, channel x_laser, daq.ripple",
        ),
        (
            "hysteresis and figures (Ch. 3)",
            False,
            CH3
            + LACKS
            + "the ripple stage, "
            + lacking("ch3.series_10hz", "ch3.series_1hz", "ch3.series_0p1hz"),
        ),
        (
            "identify (Ch. 4)",
            False,
            IDENTIFY
            + LACKS
            + "the ripple stage, "
            + lacking(
                "identify.set",
                "identify.static_free",
                "identify.static_blocked",
                "identify.force_record",
                "identify.recovery_drive",
            ),
        ),
        ("gamma (Ch. 5)", False, GAMMA + LACKS + "the ripple stage, " + lacking("gamma.fit")),
        (
            "observer (Ch. 5)",
            False,
            OBSERVER
            + LACKS
            + "the gamma stage, "
            + lacking("observer.sine", "observer.creep", "observer.study"),
        ),
        (
            "frequency response (Ch. 5, Fig 5.3)",
            False,
            SWEEP + LACKS + "the identify stage, " + lacking("frequency_response.sweep"),
        ),
        (
            "control (Ch. 6)",
            False,
            CONTROL + LACKS + "the observer stage, the identify stage, " + lacking(*PROFILE_ROLES),
        ),
        (
            "thermal (Ch. 7)",
            False,
            THERMAL
            + LACKS
            + "the observer stage, the identify stage, "
            + lacking(
                "thermal.heating",
                "thermal.voltage",
                "thermal.check",
                "thermal.gamma_t_fit",
                "thermal.gamma_t_validation",
                "thermal.coupled_fig_7_10",
                "thermal.coupled_fig_7_11",
                "thermal.coupled_fig_7_12",
            )
            + ", channel T_mid",
        ),
        ("powerloss (Ronkanen)", True, POWERLOSS),
    ],
}

#: the rules each stage gates (the verification rules too: every dataset here is simulated);
#: extract_ripple and the twin's simulations run for any stage that needs them
STAGE_RULES = {
    "characterise": {"characterise", "characterise_page"},
    "ripple": {"ch3_tables"},
    "ch3": {"ch3_hysteresis", "ch3_figures", "ch3_model_figure", "ce_recovery", "ce_np_study"},
    "identify": {"static_stiffness", "identify", "ch4_figures", "model_recovery"},
    "gamma": {"gamma_fit", "curve_vs_thesis", "gamma_truth"},
    "observer": {
        "charge_sensing",
        "observe",
        "ch5_tables",
        "observer_study",
        "ch5_figures",
        "error_budget",
        "charge_budget",
    },
    "frequency_response": {"frequency_response"},
    "control": {
        "simulate_closed_loop",
        "audit_realtime",
        "ch6_results",
        "ch6_figures",
        "tracking_budget",
        "loop_leak",
    },
    "thermal": {
        "thermal_extract",
        "thermal_identify",
        "thermal_checks",
        "gamma_t_fit",
        "frequency_effect",
        "estimator_diagram",
        "coupled",
        "ch7_summary",
        "thermal_recovery",
        "temperature_budget",
    },
    "powerloss": {
        "powerloss_identify",
        "powerloss_table_2",
        "powerloss_performance",
        "powerloss_figures",
        "powerloss_recovery",
        "powerloss_truth",
    },
}
#: rules of two stages (the curves are Γ's and Γ_T's): gated by either
SHARED = {"curve_vs_thesis": {"gamma", "thermal"}, "gamma_truth": {"gamma", "thermal"}}


def experiments(manifest, campaign="smoke"):
    return expand_protocols(manifest["protocols"], campaign, PROTOCOLS)


def plan(manifest, campaign="smoke"):
    return stages.plan_stages(manifest, experiments(manifest, campaign))


def without_channels(manifest, *channels):
    doc = copy.deepcopy(manifest)
    doc["daq"]["channels"] = [c for c in doc["daq"]["channels"] if c not in channels]
    for c in channels:
        doc["daq"]["ranges"].pop(c, None)
    return doc


def without_protocols(manifest, *protocols):
    doc = copy.deepcopy(manifest)
    doc["protocols"] = [p for p in doc["protocols"] if p not in protocols]
    return doc


#: variants of the stack's manifest and the stages each skips ({name: (edit, skipped stages)})
VARIANTS = {
    "no_ripple": (
        lambda m: without_channels(m, "Ur", "Ir"),
        {
            "ripple",
            "ch3",
            "identify",
            "gamma",
            "observer",
            "frequency_response",
            "control",
            "thermal",
        },
    ),
    "no_ch3": (lambda m: without_protocols(m, "ch3"), {"ch3"}),
    "no_t_mid": (lambda m: without_channels(m, "T_mid"), {"thermal"}),
    "no_ch6": (lambda m: without_protocols(m, "ch6"), {"control"}),
}


@pytest.fixture(scope="module")
def stack():
    return load_dataset(ROOT / "raw", "pi_p885")


@pytest.mark.parametrize("campaign", ["thesis", "smoke"])
@pytest.mark.parametrize("dataset", sorted(SHIPPED))
def test_the_shipped_datasets_plans_are_their_stages_tables(dataset, campaign):
    rows = plan(load_dataset(ROOT / "raw", dataset), campaign).rows()
    assert [(r["stage"], r["runs"], r["needs"]) for r in rows] == SHIPPED[dataset]


def test_every_stage_is_a_row_after_the_stages_it_builds_on():
    keys = [s.key for s in stages.STAGES]
    assert len(set(keys)) == len(keys) == len({s.title for s in stages.STAGES})
    for i, stage in enumerate(stages.STAGES):
        assert set(stage.after) <= set(keys[:i]), stage.key
    assert "ch3" in keys  # Chapter 3's tables and figures have a row of their own


@pytest.mark.parametrize("variant", sorted(VARIANTS))
def test_a_dataset_skips_exactly_the_stages_it_lacks_something_for(stack, variant):
    edit, skipped = VARIANTS[variant]
    shipped = plan(stack)
    result = plan(edit(stack))
    expected = set(shipped.running()) - skipped
    assert set(result.running()) == expected
    for row, stage in zip(result.rows(), stages.STAGES, strict=True):
        assert row["runs"] == result.runs(stage.key) == (not result.lacks[stage.key])
        # a skipped stage always says what the dataset lacks; a running one says what it needs
        assert (LACKS in row["needs"]) != row["runs"]
        assert row["needs"].startswith(stage.needs)


def test_without_the_ripple_channels_every_ripple_stage_names_what_is_missing(stack):
    result = plan(without_channels(stack, "Ur", "Ir"))
    assert result.lacks["ripple"] == ("channel Ur", "channel Ir")
    assert result.lacks["ch3"] == ("the ripple stage",)
    assert result.lacks["observer"] == ("the gamma stage",)
    assert result.lacks["control"] == ("the observer stage", "the identify stage")
    assert result.runs("characterise")


def test_without_the_chapter_3_runs_ripple_runs_and_chapter_3_says_what_it_lacks(stack):
    result = plan(without_protocols(stack, "ch3"))
    assert result.runs("ripple") and not result.runs("ch3")
    assert ", ".join(result.lacks["ch3"]) == lacking(
        "ch3.series_10hz", "ch3.series_1hz", "ch3.series_0p1hz"
    )


def test_a_running_stage_needs_its_manifest_keys_and_a_skipped_one_does_not(stack):
    bare = copy.deepcopy(stack)
    del bare["actuator"]["thermal"]
    with pytest.raises(ManifestError, match=r"actuator\.thermal .*the thermal \(Ch\. 7\) stage"):
        stages.check_manifest_keys(bare, plan(bare), "raw/pi_p885/dataset.yaml")
    skipped = without_channels(bare, "T_mid")
    stages.check_manifest_keys(skipped, plan(skipped), "raw/pi_p885/dataset.yaml")


def test_rule_files_hold_rules_and_what_they_make_and_common_smk_the_rest():
    """The gating is the plan's: every *_DATASETS list is derived in common.smk, and the other
    rule files define nothing at module level but their rules and their *_OUTPUTS lists."""
    rules = ROOT / "workflow" / "rules"
    allowed = re.compile(r"rule \w+:|if (SIMULATED|MEASURED):|[A-Z_]+_OUTPUTS = .*|[)\]].*|#.*|")
    outputs = []
    for path in sorted(rules.glob("*.smk")):
        if path.name != "common.smk":
            top = [line for line in path.read_text().splitlines() if not line[:1].isspace()]
            assert [line for line in top if not allowed.fullmatch(line)] == [], path.name
            outputs += [line.split(" = ")[0] for line in top if "_OUTPUTS = " in line]
    assert len(outputs) == len(set(outputs))  # each list made once, by its stage's file
    common = (rules / "common.smk").read_text()
    for stage in stages.STAGE_KEYS:
        assert f'_DATASETS = datasets_running("{stage}")' in common, stage


def test_a_simulated_dataset_has_its_closed_loops_only_when_the_control_stage_runs(stack):
    catalogue = list(experiments(stack))
    assert stages.captures_made(stack, experiments(stack), plan(stack)) == catalogue
    bare = without_channels(stack, "Ur", "Ir")  # no model to run the loop with
    made = stages.captures_made(bare, experiments(bare), plan(bare))
    assert (
        made
        == [e for e in catalogue if e not in stages.closed_loop(experiments(stack))]
        != catalogue
    )
    measured = bare | {"source": "measured"}  # a measured dataset's captures are given
    assert stages.captures_made(measured, experiments(measured), plan(measured)) == catalogue


def scheduled(dry_run_output):
    """{dataset: {rule a dry run schedules for it: the outputs of its jobs}}."""
    jobs = {}
    for rule, block in re.findall(r"^(?:local)?rule (\w+):\n((?:    .*\n)+)", dry_run_output, re.M):
        dataset = re.search(r"wildcards: .*?\bdataset=([\w~-]+)", block)
        if dataset:
            output = re.search(r"^    output: (.*)$", block, re.M)
            outputs = jobs.setdefault(dataset[1], {}).setdefault(rule, [])
            outputs += output[1].split(", ") if output else []
    return jobs


@pytest.fixture(scope="module")
def dry_run(tmp_path_factory, stack):
    """A dry run of the smoke campaign on the shipped datasets and the stack's variants, in a
    scratch copy: {dataset: the rules scheduled for it}, and the plans."""
    repo = copy_repo(tmp_path_factory.mktemp("plan") / "repo")
    for name, (edit, _) in VARIANTS.items():
        doc = edit(stack) | {"name": name}
        (repo / "raw" / name).mkdir()
        (repo / "raw" / name / "dataset.yaml").write_text(yaml.safe_dump(doc, allow_unicode=True))
    config = yaml.safe_load((repo / SMOKE_CONFIG).read_text())
    config["datasets"] = [*SHIPPED, *VARIANTS]
    (repo / "plan.yaml").write_text(yaml.safe_dump(config))
    # and an envelope member on its own: the run's datasets and one member
    run = run_snakemake(repo, "-n", "all", f"results/{MEMBER}/scorecard.csv", config="plan.yaml")
    assert run.returncode == 0, run.stderr[-4000:]
    plans = {d: plan(load_dataset(repo / "raw", d)) for d in config["datasets"]}
    return scheduled(run.stdout + run.stderr), plans


#: the smoke envelope's first member
MEMBER = "pi_p885~01"


def test_the_workflow_schedules_a_stages_rules_exactly_when_the_plan_runs_it(dry_run):
    jobs, plans = dry_run
    assert set(jobs) - {MEMBER} == set(plans)
    for dataset, result in plans.items():
        for stage, rules in STAGE_RULES.items():
            for rule in rules:
                runs = any(result.runs(s) for s in SHARED.get(rule, {stage}))
                assert (rule in jobs[dataset]) == runs, (dataset, stage, rule)


def test_an_envelope_member_draws_only_the_figure_that_comes_with_a_table_it_reads(dry_run):
    """A member's scorecard reads tables only: Chapter 6's figures are a rule apart from its
    tables, so a member draws none of them; Fig 5.3 is made by the rule of the resonance table."""
    jobs, _ = dry_run
    member = jobs[MEMBER]
    assert {"simulate_closed_loop", "ch6_results", "scorecard"} <= set(member)
    drawn = [o for made in member.values() for o in made if o.startswith("figures/")]
    assert drawn == [f"figures/{MEMBER}/fig_5_3.png"]
    assert "ch6_figures" in jobs["pi_p885"]


def catalogue_names():
    """Every run name of the shipped catalogue, as the thesis campaign expands it, and the
    prefixes its families share (ch5_sine_, rk_ramp_ …): what no rule or library module may
    spell, since a stage reads its runs by role."""
    names = set()
    for path in sorted(PROTOCOLS.glob("*.yaml")):
        names |= set(expand_protocols([path.stem], "thesis", PROTOCOLS))
    families = {"_".join(n.split("_")[:2]) + "_" for n in names}
    return names, families


def test_no_rule_and_no_library_module_names_a_run_of_the_catalogue():
    names, families = catalogue_names()
    words = re.compile(r"\b(" + "|".join(sorted(names | families, key=len, reverse=True)) + ")")
    found = []
    places = [
        *(ROOT / "workflow" / "rules").glob("*.smk"),
        *(ROOT / "workflow" / "scripts").glob("*.py"),
        *(ROOT / "src" / "selfsense").rglob("*.py"),
    ]
    assert {"ch4_sine_", "ch6_p1_", "rk_ramp_", "ch5_sweep"} <= names | families
    for path in places:
        for k, line in enumerate(path.read_text().splitlines(), 1):
            for m in words.finditer(line):
                found.append(f"{path.relative_to(ROOT)}:{k}: {m.group(0)}")
    assert found == []
