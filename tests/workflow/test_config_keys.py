"""Config reaches the rules only through their params: changing one config key reruns the rules
that declare it (Snakemake's params trigger, or their inputs being remade when one of them is
downstream of another), no rule that does not declare it for its params, and everything else only
because its inputs are remade.

Which rule declares which key is read from the workflow's source in one parse: Snakemake's own
parser turns each rule file into Python, and every ``config[...]`` a rule's params read, directly
or through a name of the rule files (``FIGURE_PDF = config["figures"]["pdf"]``), is followed.
A few dry runs on a copy of the session's up-to-date smoke tree (`config_tree`) then hold the
parse to what Snakemake does: its params trigger reruns exactly the rules the parse names."""

import ast
import re
import types

import pytest
import yaml

from selfsense.io.manifest import load_config

from ..helpers import ROOT, SMOKE_CONFIG, copy_smoke_tree, run_snakemake

SMOKE = ROOT / SMOKE_CONFIG
RULE_FILES = [ROOT / "Snakefile", *sorted((ROOT / "workflow" / "rules").glob("*.smk"))]

#: the rules named by a loop variable, by that variable: one a protocol simulated together
#: (rule ``simulate_<protocol>``, common.smk's ``simulated_together``)
NAMED_IN_A_LOOP = {
    "_name": {f"simulate_{p}" for p in yaml.safe_load(SMOKE.read_text())["twin"]["together"]}
}

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
#: the envelope's design, which its own rules take whole as a param: read by another rule's
#: inputs, it says which datasets are its members (rule all and the scorecard leave them out);
#: and the validation's plan, which says which members and batches exist (its rules take what it
#: draws as their params: a member's manifest, a batch's runs)
STRUCTURAL_SECTIONS = ("envelope.", "validation.")

#: a few keys and the rules that read them, as the rule files say: the parse must find these
KNOWN = {
    "gamma.orders": {"gamma_fit", "ch5_figures"},
    "observer.omega_s": {"charge_sensing"},
    "thermal.gamma_t_order": {"gamma_t_fit"},
    "figures.pdf": {"ch3_figures", "ch5_figures", "powerloss_figures", "envelope"},
    "capture.compression": {"simulate", "simulate_closed_loop", *NAMED_IN_A_LOOP["_name"]},
}

#: the rule files whose rules only `snakemake envelope` and `snakemake validate` run, not the
#: default target
OWN_TARGETS = {ROOT / "workflow" / "rules" / f for f in ("envelope.smk", "validation.smk")}

#: the keys the dry runs change, with a changed value: one read directly, one through a name of
#: the rule files, one taken as a whole section by the rules a loop names
DRY_RUNS = {
    "gamma.orders": [3, 4],
    "figures.pdf": True,
    "capture.compression": "zlib",
}


def leaves(doc, prefix=""):
    for key, value in doc.items():
        if isinstance(value, dict):
            yield from leaves(value, f"{prefix}{key}.")
        else:
            yield f"{prefix}{key}"


#: every leaf the workflow sees: smoke.yaml, config.yaml and the schema's defaults
SEEN = set(leaves(load_config(SMOKE))) | set(leaves(load_config(ROOT / "config.yaml")))


# -- the parse ------------------------------------------------------------------------------------


def compiled(path) -> ast.Module:
    """A rule file as the Python Snakemake makes of it (its parser alone: nothing is run)."""
    from snakemake import parser

    source = types.SimpleNamespace(get_path_or_uri=lambda secret_free=True: str(path))
    opened = types.SimpleNamespace(open=lambda _: open(path, encoding="utf-8"))
    code, _ = parser.parse(source, types.SimpleNamespace(sourcecache=opened), {})
    return ast.parse(code)


def config_reads(node) -> set[str]:
    """The keys ``config["a"]["b"]…`` read in ``node``, dotted; a section read whole by its
    prefix ("characterise.cycles")."""
    chains, inner = {}, set()
    for n in ast.walk(node):
        path, v = [], n
        while (
            isinstance(v, ast.Subscript)
            and isinstance(v.slice, ast.Constant)
            and isinstance(v.slice.value, str)
        ):
            path.append(v.slice.value)
            v = v.value
            inner.add(id(v))
        if path and isinstance(v, ast.Name) and v.id == "config":
            chains[id(n)] = ".".join(reversed(path))
    return {key for i, key in chains.items() if i not in inner}


def names(node) -> set[str]:
    return {n.id for n in ast.walk(node) if isinstance(n, ast.Name)}


def module_names(modules) -> dict[str, list[ast.AST]]:
    """{name: the definitions that bind it}: the rule files' assignments and functions outside
    any function (in an ``if`` or a ``for`` too; a function's own locals are its body's). A name
    extended in place keeps its first binding's keys: ``DATASETS |= ENVELOPE.manifests`` adds the
    envelope's members, datasets whose jobs a change to the envelope's design makes or drops, not
    reruns."""
    bound = {}

    def bind(target, value):
        for name in names(target):
            bound.setdefault(name, []).append(value)

    def visit(statements):
        for n in statements:
            if isinstance(n, ast.FunctionDef) and not n.name.startswith("__rule_"):
                bound.setdefault(n.name, []).append(n)
            elif isinstance(n, ast.Assign):
                for target in n.targets:
                    bind(target, n.value)
            elif isinstance(n, ast.AnnAssign) and n.value is not None:
                bind(n.target, n.value)
            elif isinstance(n, ast.For):
                bind(n.target, n.iter)
            for block in ("body", "orelse", "finalbody"):
                if not isinstance(n, ast.FunctionDef | ast.ClassDef) and hasattr(n, block):
                    visit(getattr(n, block))

    for module in modules:
        visit(module.body)
    return bound


def resolver(bound):
    """The keys an expression reads: its own ``config[...]`` and, through every name it uses,
    those of the name's definitions (followed to the end, each name once)."""
    memo = {}

    def of_name(name):
        if name not in memo:
            memo[name] = set()  # a name that refers to itself adds nothing
            memo[name] = set().union(*(keys(d) for d in bound.get(name, ())))
        return memo[name]

    def keys(node):
        return config_reads(node).union(*(of_name(n) for n in names(node) if n != "config"))

    return keys


def directive(decorator) -> str | None:
    """``params`` of ``@workflow.params(...)``."""
    if isinstance(decorator, ast.Call) and isinstance(decorator.func, ast.Attribute):
        if isinstance(decorator.func.value, ast.Name) and decorator.func.value.id == "workflow":
            return decorator.func.attr
    return None


def rule_name(function) -> set[str]:
    """The names of the rule that ``def __rule_…`` runs (a rule named in a loop has several)."""
    for d in function.decorator_list:
        if directive(d) == "rule" and (given := d.keywords[0].value).value is not None:
            return {given.value}
        if directive(d) == "name":
            return NAMED_IN_A_LOOP[d.args[0].id]
    raise AssertionError(f"no name for {function.name}")


def rules_and_reads():
    """{rule: ({key its params read}, {key its other directives read}, its file)}, one parse."""
    modules = {path: compiled(path) for path in RULE_FILES}
    keys = resolver(module_names(modules.values()))
    found = {}
    for path, module in modules.items():
        for function in ast.walk(module):
            if not (isinstance(function, ast.FunctionDef) and function.name.startswith("__rule_")):
                continue
            params, other = set(), set()
            for d in function.decorator_list:
                if directive(d) == "params":
                    params |= keys(d)
                elif directive(d) not in (None, "rule", "name", "docstring"):
                    other |= keys(d)
            for name in rule_name(function):
                found[name] = (params, other, path)
    return found


RULES = rules_and_reads()


def leaves_of(key: str) -> set[str]:
    """The config's leaves a read of ``key`` covers: itself, or a section's leaves."""
    return {k for k in SEEN if k == key or k.startswith(f"{key}.")}


def declared() -> dict[str, set[str]]:
    """{config leaf: the rules whose params read it}."""
    uses = {}
    for rule, (params, _, _) in RULES.items():
        for leaf in set().union(*map(leaves_of, params)):
            uses.setdefault(leaf, set()).add(rule)
    return uses


USES = declared()


def test_the_parse_finds_every_rule_of_the_rule_files():
    named = {m for p in RULE_FILES for m in re.findall(r"^\s*rule (\w+):", p.read_text(), re.M)}
    in_a_loop = set().union(*NAMED_IN_A_LOOP.values())
    assert set(RULES) == named | in_a_loop
    assert len(RULES) > 50


def test_the_parse_finds_what_the_rule_files_say():
    for key, rules in KNOWN.items():
        assert rules <= USES[key], (key, USES.get(key))
    # a section a rule takes whole covers each of its keys
    assert {"characterise_page"} <= USES["characterise.cycles.full_tolerance"]
    assert config_reads(ast.parse('f(config["a"]["b"], x=config["c"], y=d["e"])')) == {"a.b", "c"}


def test_every_setting_reaches_a_rule_through_its_params():
    """Every key of the config is a setting some rule declares in its params (or a job size, or
    it shapes the DAG): no key is dead, and none is misspelt in a rule."""
    settings = {k for k in SEEN if not k.startswith(RESOURCES)} - STRUCTURAL
    assert settings - set(USES) == set()
    assert set(USES) - SEEN == set()


def test_a_rule_that_reads_a_setting_declares_it_in_its_params():
    """A setting a rule's input functions, outputs, wildcards or priority read is also one of its
    params, so that the params trigger reruns it when the setting changes."""
    undeclared = {}
    for rule, (params, other, _) in RULES.items():
        covered = set().union(*map(leaves_of, params))
        read = set().union(*map(leaves_of, other)) - STRUCTURAL
        left = {k for k in read - covered if not k.startswith((RESOURCES, *STRUCTURAL_SECTIONS))}
        if left:
            undeclared[rule] = sorted(left)
    assert undeclared == {}


# -- what Snakemake does --------------------------------------------------------------------------


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


@pytest.mark.slow
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


@pytest.mark.slow
@pytest.mark.parametrize("key", DRY_RUNS)
def test_a_config_change_reruns_exactly_the_rules_that_declare_it(config_tree, tmp_path, key):
    # the rules the parse names, but those only `snakemake envelope` or `validate` runs
    rules = {r for r in USES[key] if RULES[r][2] not in OWN_TARGETS}
    changed = tmp_path / "changed.yaml"
    changed.write_text(yaml.safe_dump(with_change(key, DRY_RUNS[key]), sort_keys=False))
    dry = run_snakemake(config_tree, "-n", "--quiet", "rules", config=str(changed))
    assert dry.returncode == 0, dry.stderr[-2000:]
    why = reasons(dry.stdout + dry.stderr)
    # Snakemake checks a job's params only when nothing upstream of it reruns, so a rule that
    # declares the key shows under "params" or, downstream of another one, under "input files"
    by_params = why.pop("params have changed since last execution", set())
    assert by_params and by_params <= rules, (by_params, rules)
    assert rules <= by_params | set().union(*why.values()), (rules, why)
    # every other job runs only because a job upstream of it reruns
    assert set(why) <= {"input files updated by another job"}, why
