"""Every analysis setting is a key of config.yaml, described in the config schema, documented in
docs/configuration.md (generated from the schema: the page and the schema cannot drift apart),
and read by the rules from the config: no rule's params or resources hold a number of their own."""

import io
import re
import textwrap
import tokenize

import yaml

from selfsense.io.config_docs import (
    COMMAND,
    config_schema,
    configuration_markdown,
    schema_keys,
    undocumented_keys,
)

from ..helpers import ROOT

DOCS = ROOT / "docs" / "configuration.md"
RULES = sorted((ROOT / "workflow" / "rules").glob("*.smk"))


def leaves(doc, prefix=""):
    for key, value in doc.items():
        if isinstance(value, dict):
            yield from leaves(value, f"{prefix}{key}.")
        else:
            yield f"{prefix}{key}", value


def test_the_page_is_the_schema_generated():
    text = DOCS.read_text(encoding="utf-8")
    assert text == configuration_markdown(config_schema()), f"regenerate it: {COMMAND}"
    assert COMMAND in "\n".join(text.splitlines()[:5])  # how to regenerate, in its first lines


def test_every_key_of_the_schema_has_a_description():
    assert undocumented_keys(config_schema()) == []
    assert undocumented_keys({"properties": {"a": {"properties": {"b": {}}}}}) == ["a", "a.b"]


def test_config_yaml_sets_every_key_to_its_default():
    """config.yaml holds every setting, and a key left out of a config gives the same results:
    its schema default is the value config.yaml ships with."""
    schema = config_schema()
    config = dict(leaves(yaml.safe_load((ROOT / "config.yaml").read_text())))
    settings = {k: s for k, s in schema_keys(schema) if s.get("type") != "object"}
    assert set(config) == set(settings)
    for key, sub in settings.items():
        if key not in schema["required"]:
            assert config[key] == sub["default"], key


def blocks(path, directive):
    """The text of every ``<directive>:`` block of a rule file, dedented."""
    lines = path.read_text().splitlines()
    for i, line in enumerate(lines):
        if line.strip() == f"{directive}:":
            indent = len(line) - len(line.lstrip())
            body = []
            for following in lines[i + 1 :]:
                if following.strip() and len(following) - len(following.lstrip()) <= indent:
                    break
                body.append(following)
            yield textwrap.dedent("\n".join(body))


def numbers(source):
    """The numeric literals of Python source (strings and comments are not looked into)."""
    tokens = tokenize.generate_tokens(io.StringIO(source).readline)
    return [t.string for t in tokens if t.type == tokenize.NUMBER]


def test_no_rule_has_a_number_of_its_own_in_its_params_or_resources():
    found = {
        (path.name, directive): numbers(block)
        for path in RULES
        for directive in ("params", "resources")
        for block in blocks(path, directive)
        if numbers(block)
    }
    assert found == {}
    assert numbers("a=config['x'],\nb=CH3_SERIES['10 Hz'],  # 2 Hz\nc=2.0,\n") == ["2.0"]


def test_every_rule_takes_its_resources_from_the_one_helper():
    for path in RULES:
        for block in blocks(path, "resources"):
            assert re.fullmatch(r'\*\*resources_for\("\w+"\),\s*', block), (path.name, block)
    sizes = set(config_schema()["properties"]["resources"]["properties"])
    used = {s for p in RULES for s in re.findall(r'resources_for\("(\w+)"\)', p.read_text())}
    assert used == sizes  # every size is used, and each used one is in the schema


def test_scripts_read_the_config_only_through_their_params():
    scripts = sorted((ROOT / "workflow" / "scripts").glob("*.py"))
    assert [p.name for p in scripts if "snakemake.config" in p.read_text()] == []


def test_scripts_are_entry_points_of_at_most_50_lines():
    """A script reads its inputs, calls the library and writes its outputs: its logic is in
    src/selfsense, where it is tested and reused."""
    long = {
        p.name: n
        for p in sorted((ROOT / "workflow" / "scripts").glob("*.py"))
        if (n := len(p.read_text(encoding="utf-8").splitlines())) > 50
    }
    assert not long, long
