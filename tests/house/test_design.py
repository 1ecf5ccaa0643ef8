"""docs/design.md describes the code as it is: its Architecture names every module of the library,
and every module (or module attribute) it names exists.

Modules are named in dotted form, `selfsense.io.capture`; a package by its own name
(`selfsense.io`), the top package as `selfsense`. The page uses that form only: a module written
as a path (`src/selfsense/io/capture.py`) fails here, while paths of package data
(`src/selfsense/io/schemas/`) must exist. So adding, removing or renaming a module without the
page, or the page naming what is gone, fails this test.
"""

import ast
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
PACKAGE = ROOT / "src" / "selfsense"
DESIGN = ROOT / "docs" / "design.md"

#: a dotted name that starts with the package: `selfsense`, `selfsense.io`, `selfsense.io.capture.X`
DOTTED = re.compile(r"(?<![\w./-])selfsense(?:\.[A-Za-z_]\w*)*(?![\w-])")
#: a path inside the package's source folder
PATH = re.compile(r"src/selfsense(?:/[\w.-]+)*/?")


def modules() -> dict[str, Path]:
    """Every module and package of the library by dotted name, with its file."""
    found = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
        if parts[-1] == "__init__":
            parts = parts[:-1]
        found[".".join(parts)] = path
    return found


def top_level_names(path: Path) -> set[str]:
    """What a module defines at its top level (functions, classes, assignments, imports)."""
    names = set()
    for node in ast.parse(path.read_text(encoding="utf-8")).body:
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            names.add(node.name)
        elif isinstance(node, (ast.Assign, ast.AnnAssign, ast.AugAssign)):
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            for target in targets:
                names |= {n.id for n in ast.walk(target) if isinstance(n, ast.Name)}
        elif isinstance(node, (ast.Import, ast.ImportFrom)):
            names |= {(a.asname or a.name).split(".")[0] for a in node.names}
    return names


def resolves(name: str, known: dict[str, Path]) -> bool:
    """A dotted name is a module or package, or a top-level name of the longest module it
    starts with (`selfsense.twin.record.record_block`)."""
    if name in known:
        return True
    parts = name.split(".")
    for cut in range(len(parts) - 1, 0, -1):
        module = ".".join(parts[:cut])
        if module in known:
            return parts[cut] in top_level_names(known[module])
    return False


def named(text: str) -> set[str]:
    return set(DOTTED.findall(text))


def test_the_architecture_names_every_module_of_the_library():
    text = DESIGN.read_text(encoding="utf-8")
    missing = sorted(m for m in modules() if m not in named(text))
    assert not missing, f"docs/design.md does not name {', '.join(missing)}"


def test_every_module_the_page_names_exists():
    known = modules()
    gone = sorted(n for n in named(DESIGN.read_text(encoding="utf-8")) if not resolves(n, known))
    assert not gone, f"docs/design.md names what the library does not have: {', '.join(gone)}"


def test_the_page_names_modules_in_one_form_and_its_paths_exist():
    text = DESIGN.read_text(encoding="utf-8")
    paths = PATH.findall(text)
    as_files = sorted(p for p in paths if p.endswith(".py"))
    assert not as_files, f"docs/design.md names modules as files, not dotted: {as_files}"
    absent = sorted(p for p in paths if not (ROOT / p).exists())
    assert not absent, f"docs/design.md names paths that do not exist: {absent}"


def test_the_checks_fail_on_a_module_the_page_does_not_have():
    """The checks above can fail: a module named on no page, and a name with no module."""
    known = modules() | {"selfsense.methods.phantom": PACKAGE / "methods" / "phantom.py"}
    assert "selfsense.methods.phantom" not in named(DESIGN.read_text(encoding="utf-8"))
    assert not resolves("selfsense.methods.phantom", modules())
    assert not resolves("selfsense.io.capture.no_such_function", modules())
    assert resolves("selfsense.io.capture", known)
    assert named("`selfsense.io.capture`, `selfsense.io`; selfsense-slurm") == {
        "selfsense.io.capture",
        "selfsense.io",
    }
