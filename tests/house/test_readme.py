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


def test_ci_runs_exactly_the_readme_test_command():
    """CI's first command is the README's test command; after it come only the linters that
    command installed (tools from .venv/bin, none of them pytest)."""
    readme = (ROOT / "README.md").read_text()
    assert TEST_COMMAND in readme and REPRODUCE_COMMAND in readme
    commands = [
        line
        for line in (ROOT / ".ci" / "run").read_text().splitlines()
        if line.strip() and not line.startswith(("#", "set ", "cd "))
    ]
    assert commands[0] == TEST_COMMAND
    assert all(c.startswith(".venv/bin/") and "pytest" not in c for c in commands[1:]), commands[1:]


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
