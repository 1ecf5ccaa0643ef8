"""docs/configuration.md from the config schema: every key of config.yaml with its type, its
default and its description, generated so that the page and the schema cannot disagree.

Regenerate after editing ``selfsense/io/schemas/config.schema.yaml``::

    .venv/bin/python -m selfsense.io.config_docs docs/configuration.md

(``tests/house/test_configuration.py`` fails while the page differs from the generated text, or
while a key of the schema has no description.)
"""

from __future__ import annotations

import json
import sys
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import Any

from selfsense.io.manifest import SCHEMAS, load_yaml

SCHEMA_FILE = "src/selfsense/io/schemas/config.schema.yaml"
COMMAND = ".venv/bin/python -m selfsense.io.config_docs docs/configuration.md"


def config_schema() -> dict:
    """The config schema as the package ships it."""
    return load_yaml(SCHEMAS / "config.schema.yaml")


def schema_keys(schema: Mapping[str, Any], prefix: str = "") -> Iterator[tuple[str, Mapping]]:
    """(dotted key, its schema) of every key, an object before the keys inside it."""
    for name, sub in schema.get("properties", {}).items():
        key = f"{prefix}{name}"
        yield key, sub
        yield from schema_keys(sub, f"{key}.")


def undocumented_keys(schema: Mapping[str, Any]) -> list[str]:
    """The keys of the schema without a description."""
    return [k for k, sub in schema_keys(schema) if not str(sub.get("description", "")).strip()]


def _value(value: Any) -> str:
    return f"`{json.dumps(value, ensure_ascii=False)}`"


def _kind(sub: Mapping[str, Any]) -> str:
    """The key's type in words, with its bounds or choices."""
    if "enum" in sub:
        return "one of " + ", ".join(_value(v) for v in sub["enum"])
    kind = sub.get("type", "any")
    if kind == "array":
        return f"list of {_kind(sub.get('items', {}))}"
    bounds = [
        f"{sign} {sub[name]:g}"
        for name, sign in (
            ("minimum", "≥"),
            ("exclusiveMinimum", ">"),
            ("maximum", "≤"),
            ("exclusiveMaximum", "<"),
        )
        if name in sub
    ]
    return " ".join([kind, ", ".join(bounds)]) if bounds else kind


def _cell(text: Any) -> str:
    return " ".join(str(text).split()).replace("|", "\\|")


def _default(key: str, sub: Mapping[str, Any], required: set[str]) -> str:
    if key in required:
        return "required"
    if sub.get("type") == "object":
        return ""
    return _value(sub["default"]) if "default" in sub else ""


def _table(rows: list[tuple[str, Mapping[str, Any]]], required: set[str]) -> list[str]:
    lines = ["| key | type | default | description |", "| --- | --- | --- | --- |"]
    for key, sub in rows:
        cells = (f"`{key}`", _kind(sub), _default(key, sub, required), sub.get("description", ""))
        lines.append("| " + " | ".join(_cell(c) for c in cells) + " |")
    return lines


def configuration_markdown(schema: Mapping[str, Any]) -> str:
    """The page docs/configuration.md for the config ``schema``: the top-level keys, then a
    section per group of settings with every key inside it."""
    required = set(schema.get("required", ()))
    properties = schema.get("properties", {})
    lines = [
        "# Configuration",
        "",
        f"> Generated from `{SCHEMA_FILE}` by `selfsense.io.config_docs`: do not edit by hand.",
        f"> After changing the schema, regenerate it with `{COMMAND}`",
        "> (`tests/house/test_configuration.py` fails while this page and the schema differ).",
        "",
        "Every setting of the pipeline is a key of `config.yaml`, which is validated against the "
        "schema before anything runs; a `--configfile` (such as `tests/config/smoke.yaml`) or "
        "`--config key=value` overrides it. A key left out takes its default, the value "
        "`config.yaml` ships with, so results do not change. The rules read the settings only "
        "through their `params:` (a changed setting reruns exactly the rules that declare it) and "
        "their `resources:` through one helper, `resources_for` in `workflow/rules/common.smk`. "
        "What is a fact of an experiment rather than a setting (a run's drive frequency, which "
        "runs a table is computed from) comes from the manifests and the experiment catalogue "
        "(`workflow/protocols`), and which stages run for a dataset from its stage plan "
        "(`selfsense.stages`, `results/<dataset>/stages.csv`).",
        "",
        "## Top level",
        "",
        *_table([(k, s) for k, s in properties.items() if s.get("type") != "object"], required),
    ]
    for name, sub in properties.items():
        if sub.get("type") != "object":
            continue
        rows = [(k, s) for k, s in schema_keys(sub, f"{name}.")]
        lines += [
            "",
            f"## `{name}`",
            "",
            _cell(sub.get("description", "")),
            "",
            *_table(rows, required),
        ]
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> None:
    """Write the page to the path given, or print it."""
    argv = sys.argv[1:] if argv is None else argv
    text = configuration_markdown(config_schema())
    if argv:
        Path(argv[0]).write_text(text, encoding="utf-8")
    else:
        sys.stdout.write(text)


if __name__ == "__main__":
    main()
