"""The library's house: layers you can see in its folders, no import cycle, light subpackages.

The layer order itself (io → methods → chapters | twin → verify → scorecard → cli) is
import-linter's contract in pyproject.toml, which CI runs as `lint-imports`; these tests hold what
that contract does not: cycles inside a layer, what stays at the top, and __init__ files that
import nothing (every job's start-up pays for what a package's __init__ imports).
"""

import ast
import re
import subprocess
import sys
from pathlib import Path

import grimp

PACKAGE = Path(__file__).resolve().parents[2] / "src" / "selfsense"
#: what may stand at the top of the package: its version, the command line, the stage plan
TOP = {"__init__.py", "cli.py", "stages.py"}


def cycles(graph: grimp.ImportGraph) -> list[list[str]]:
    """Every import cycle among the package's modules (each found once, from its first module)."""
    found, done = [], set()

    def visit(module, path, on_path):
        for imported in sorted(graph.find_modules_directly_imported_by(module)):
            if imported in on_path:
                found.append(path[path.index(imported) :] + [imported])
            elif imported not in done:
                visit(imported, path + [imported], on_path | {imported})
        done.add(module)

    for module in sorted(graph.modules):
        if module not in done:
            visit(module, [module], {module})
    return found


def test_no_module_imports_itself_back():
    graph = grimp.build_graph("selfsense")
    assert cycles(graph) == []


def test_the_cycle_finder_finds_a_cycle(tmp_path, monkeypatch):
    """The check above can fail: two modules that import each other are reported."""
    pkg = tmp_path / "loopy"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("")
    (pkg / "a.py").write_text("from loopy import b\n")
    (pkg / "b.py").write_text("from loopy import a\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    assert cycles(grimp.build_graph("loopy", cache_dir=None)) == [["loopy.a", "loopy.b", "loopy.a"]]


def test_at_most_three_modules_stand_at_the_top():
    assert {p.name for p in PACKAGE.glob("*.py")} <= TOP


def test_subpackage_inits_import_nothing_and_map_their_subpackage():
    for init in sorted(PACKAGE.glob("*/__init__.py")):
        tree = ast.parse(init.read_text())
        imports = [n for n in ast.walk(tree) if isinstance(n, (ast.Import, ast.ImportFrom))]
        assert not imports, f"{init} imports {ast.unparse(imports[0])}"
        doc = ast.get_docstring(tree) or ""
        modules = {p.stem for p in init.parent.glob("*.py")} - {"__init__"}
        unnamed = sorted(m for m in modules if f"``{m}``" not in doc)
        assert not unnamed, f"{init}'s docstring does not map {', '.join(unnamed)}"


#: what the workflow's parse must not import: every `snakemake` start (a dry run, each SLURM job's
#: two starts) parses it, and these cost seconds; the jobs that need them import them
HEAVY = ("matplotlib", "numba", "scipy", "SALib", "xarray")


def test_parsing_the_workflow_imports_no_plotting_compiler_or_solver():
    common = (PACKAGE.parents[1] / "workflow" / "rules" / "common.smk").read_text()
    modules = sorted(
        {
            m[0] or f"selfsense.{m[1]}"
            for m in re.findall(
                r"^from (selfsense\.[\w.]+) import|^from selfsense import (\w+)", common, re.M
            )
        }
    )
    assert "selfsense.envelope.design" in modules, modules
    probe = (
        f"import sys, {', '.join(modules)}; "
        f"print(sorted({{m.split('.')[0] for m in sys.modules}} & set({HEAVY})))"
    )
    run = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, check=True)
    assert run.stdout.strip() == "[]", run.stdout
