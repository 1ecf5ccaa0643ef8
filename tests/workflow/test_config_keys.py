"""Config reaches the rules only through their params: changing one config key reruns the rules
that declare it (Snakemake's params trigger, or their inputs being remade when one of them is
downstream of another), no rule that does not declare it for its params, and everything else only
because its inputs are remade. Dry runs on a copy of the session's up-to-date smoke tree
(`config_tree`), so that they run beside the tests that use the tree itself, not after them."""

import re

import pytest
import yaml

from selfsense.io.manifest import load_config

from ..helpers import ROOT, SMOKE_CONFIG, copy_smoke_tree, run_snakemake

pytestmark = pytest.mark.slow

SMOKE = ROOT / SMOKE_CONFIG

#: the rules that simulate a capture: one a run, a protocol's runs together, a closed loop
SIMULATE = {"simulate", "simulate_closed_loop"} | {
    f"simulate_{p}" for p in yaml.safe_load(SMOKE.read_text())["twin"]["together"]
}

#: config key: (a changed value, the rules whose params declare it; see workflow/rules/*.smk)
USES = {
    "ripple.n_periods": (
        5,
        {
            "extract_ripple",
            "ce_recovery",
            "gamma_fit",
            "observe",
            "observer_study",
            "charge_budget",
            "ch5_figures",
            "simulate_closed_loop",
            "audit_realtime",
            "thermal_extract",
            "estimator_diagram",
            "coupled",
            "error_budget",
        },
    ),
    "ripple.np_sweep": ([1, 2, 4], {"ce_np_study"}),
    "gamma.orders": ([3, 4], {"gamma_fit", "ch5_figures"}),
    "observer.omega_s": (3.0, {"charge_sensing"}),
    "observer.zeta_s": (0.7, {"charge_sensing"}),
    "observer.sweep_settle_s": (0.03, {"frequency_response"}),
    "observer.creep_transient_s": (2.0, {"observe", "error_budget"}),
    "observer.study_omegas": ([1.0, 6.283], {"observer_study"}),
    "observer.study_offsets": ([0.0], {"observer_study"}),
    "control.omega_c": (1000.0, {"simulate_closed_loop", "ch6_results", "tracking_budget"}),
    "capture.chunk_len": (32768, SIMULATE),
    "capture.compression": ("zlib", SIMULATE),
    "capture.complevel": (2, SIMULATE),
    "capture.truth_decimation": (6, SIMULATE),
    "characterise.settle_s": (0.2, {"characterise_page"}),
    "characterise.min_hold_s": (2.0, {"characterise_page"}),
    "ripple.skip_s": (0.2, {"ch3_hysteresis", "ch3_figures"}),
    "ripple.np_study_wander_hz": ([0, 50], {"ce_np_study"}),
    "ripple.np_study_drive_hz": (50.0, {"ce_np_study"}),
    "identify.static_hold_s": (0.6, {"static_stiffness"}),
    "thermal.power_interval_s": (0.2, {"thermal_extract"}),
    "thermal.gamma_t_every": (100, {"thermal_extract"}),
    "thermal.gamma_t_orders": ([4, 5], {"gamma_t_fit"}),
    "thermal.gamma_t_order": (4, {"gamma_t_fit"}),
    "thermal.gamma_t_candidates": ([1, 2, 3, 4, 5], {"gamma_t_fit"}),
    "thermal.frequency_effect_bins": (10, {"frequency_effect"}),
    "thermal.frequency_effect_min_windows": (5, {"frequency_effect"}),
    "powerloss.velocity_window_s": (1.0, {"powerloss_identify", "powerloss_figures"}),
    "powerloss.drift_duration_s": (60.0, {"powerloss_performance", "powerloss_truth"}),
    "characterise.cycles.full_tolerance": (0.1, {"characterise_page"}),
    # every rule that draws a figure (the envelope's only under `snakemake envelope`)
    "figures.pdf": (
        True,
        {
            "characterise_page",
            "ch3_figures",
            "ch3_model_figure",
            "ch4_figures",
            "ch5_figures",
            "observer_study",
            "frequency_response",
            "ch6_figures",
            "ce_np_study",
            "error_budget",
            "thermal_identify",
            "gamma_t_fit",
            "frequency_effect",
            "estimator_diagram",
            "ch7_summary",
            "powerloss_figures",
        },
    ),
    "characterise.hysteresis.max_order": (8, {"characterise_page"}),
    # the envelope's rules take the section whole, and only `snakemake envelope` runs them: a
    # change reruns nothing of the default run
    "envelope.seed": (7, set()),
}

#: sections a rule takes whole, as one param: a change to any of their keys changes that param,
#: so the dry run of one key (in USES) stands for the others
SECTIONS = ("characterise.cycles.", "characterise.hysteresis.", "envelope.")

#: a job's resources are no rerun trigger: changing every size at once reruns nothing
#: (test_changing_the_job_sizes_reruns_nothing)
RESOURCES = "resources."

#: keys that choose which jobs and files exist rather than what a job computes (a change makes a
#: different DAG, not a rerun of this one): captures_per_job makes the loop figure's pages
STRUCTURAL = {
    "datasets",
    "campaign",
    "raw_dir",
    "characterise.captures_per_job.simulated",
    "characterise.captures_per_job.measured",
    "twin.together",  # which runs share a job: the same captures, made by fewer jobs
}


def leaves(doc, prefix=""):
    for key, value in doc.items():
        if isinstance(value, dict):
            yield from leaves(value, f"{prefix}{key}.")
        else:
            yield f"{prefix}{key}"


def with_change(key, value):
    config = yaml.safe_load(SMOKE.read_text())
    *parents, leaf = key.split(".")
    node = config
    for p in parents:
        node = node.setdefault(p, {})
    node[leaf] = value
    return config


def reasons(output):
    """{reason: rules} from the "Reasons:" summary that ends a dry run with --quiet rules."""
    summary = output.split("Reasons:", 1)[1] if "Reasons:" in output else ""
    return {
        reason: set(rules.split(", "))
        for reason, rules in re.findall(r"^ {4}(\S[^\n]*):\n {8}(\S[^\n]*)$", summary, re.M)
    }


@pytest.fixture(scope="module")
def config_tree(smoke_run, tmp_path_factory):
    """An up-to-date copy of the smoke tree, Snakemake's records included."""
    return copy_smoke_tree(smoke_run, tmp_path_factory.mktemp("config_tree") / "repo")


def test_every_config_key_is_covered():
    # every leaf the workflow sees (smoke.yaml, config.yaml and the schema's defaults) is listed
    # here
    seen = set(leaves(load_config(SMOKE))) | set(leaves(load_config(ROOT / "config.yaml")))
    whole = {k for k in seen if k.startswith(SECTIONS)}
    assert all(any(k.startswith(prefix) for k in USES) for prefix in SECTIONS)
    assert {k for k in seen if not k.startswith(RESOURCES)} - whole == set(
        USES
    ) - whole | STRUCTURAL


def test_changing_the_job_sizes_reruns_nothing(config_tree, tmp_path):
    config = yaml.safe_load(SMOKE.read_text())
    config["resources"] = {
        size: {"mem_mb": 1234, "runtime": 77} for size in load_config(SMOKE)["resources"]
    }
    changed = tmp_path / "changed.yaml"
    changed.write_text(yaml.safe_dump(config, sort_keys=False))
    dry = run_snakemake(config_tree, "-n", "--quiet", "rules", config=str(changed))
    assert dry.returncode == 0, dry.stderr[-2000:]
    assert "Nothing to be done" in dry.stdout + dry.stderr, (dry.stdout + dry.stderr)[-2000:]


@pytest.mark.parametrize("key", USES)
def test_a_config_change_reruns_exactly_the_rules_that_declare_it(config_tree, tmp_path, key):
    value, rules = USES[key]
    changed = tmp_path / "changed.yaml"
    changed.write_text(yaml.safe_dump(with_change(key, value), sort_keys=False))
    dry = run_snakemake(config_tree, "-n", "--quiet", "rules", config=str(changed))
    assert dry.returncode == 0, dry.stderr[-2000:]
    out = dry.stdout + dry.stderr
    if not rules:
        assert "Nothing to be done" in out, out[-2000:]
        return
    why = reasons(out)
    # Snakemake checks a job's params only when nothing upstream of it reruns, so a rule that
    # declares the key shows under "params" or, downstream of another one, under "input files"
    by_params = why.pop("params have changed since last execution", set())
    assert by_params and by_params <= rules, (by_params, rules)
    assert rules <= by_params | set().union(*why.values()), (rules, why)
    # every other job runs only because a job upstream of it reruns
    assert set(why) <= {"input files updated by another job"}, why
