"""The README's two commands are what CI and users run."""

from ..helpers import ROOT

TEST_COMMAND = (
    "python3.11 -m venv .venv && .venv/bin/pip install -q -c constraints.txt -e '.[test]'"
    " && .venv/bin/pytest"
)
REPRODUCE_COMMAND = (
    "python3.11 -m venv .venv && .venv/bin/pip install -q -c constraints.txt -e ."
    " && .venv/bin/snakemake --cores 2"
)


#: what CI runs between the test command's install and its pytest, in this order: the linters the
#: install brought, each of them seconds, so that a lint slip fails before the ten-minute suite
LINTERS = (
    ".venv/bin/ruff check .",
    ".venv/bin/ruff format --check .",
    ".venv/bin/lint-imports",
    ".venv/bin/snakefmt --check Snakefile workflow/rules",
    ".venv/bin/python scripts/lint_workflow.py",
)


def ci_commands():
    return [
        line
        for line in (ROOT / ".ci" / "run").read_text().splitlines()
        if line.strip() and not line.startswith(("#", "set ", "cd "))
    ]


def test_ci_runs_exactly_the_readme_test_command_with_the_linters_before_its_pytest():
    """CI runs the README's test command, split at its last ``&&``: its install first, its pytest
    last, and between them only the linters (tools from .venv/bin, none of them pytest). Under
    ``set -e`` the first linter that fails ends the run before pytest starts."""
    readme = (ROOT / "README.md").read_text()
    assert TEST_COMMAND in readme and REPRODUCE_COMMAND in readme
    install, pytest_ = TEST_COMMAND.rsplit(" && ", 1)
    commands = ci_commands()
    assert " && ".join([commands[0], commands[-1]]) == TEST_COMMAND, commands
    assert (commands[0], commands[-1]) == (install, pytest_)
    assert tuple(commands[1:-1]) == LINTERS, commands[1:-1]
    assert all(c.startswith(".venv/bin/") and "pytest" not in c for c in commands[1:-1])
    assert "set -euo pipefail" in (ROOT / ".ci" / "run").read_text()


def test_the_pre_commit_hooks_are_the_ci_linters():
    """.pre-commit-config.yaml runs the same linters as CI, as local hooks with the venv's tools
    (nothing fetched at commit time)."""
    import yaml

    config = yaml.safe_load((ROOT / ".pre-commit-config.yaml").read_text())
    assert [r["repo"] for r in config["repos"]] == ["local"]
    hooks = config["repos"][0]["hooks"]
    assert all(h["language"] == "system" for h in hooks)
    entries = {h["entry"] for h in hooks}
    # each CI linter is a hook's entry, its arguments up to the paths the hook is given
    for linter in LINTERS:
        assert any(linter.startswith(e) for e in entries), linter


def test_every_dependency_is_pinned():
    pins = {
        line.split("==")[0].lower().replace("_", "-")
        for line in (ROOT / "constraints.txt").read_text().splitlines()
        if "==" in line
    }
    import tomllib

    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    wanted = project["dependencies"] + project["optional-dependencies"]["test"]
    missing = [d for d in wanted if d.lower().replace("_", "-") not in pins]
    assert not missing, missing


def test_readme_is_an_entrance_of_at_most_150_lines():
    """Everything beyond what it reproduces, the two commands, what you get and where to go next
    lives in docs/ (`wc -l README.md` counts newline characters)."""
    lines = (ROOT / "README.md").read_bytes().count(b"\n")
    assert lines <= 150, f"README.md has {lines} lines; move material to docs/"
