"""`snakemake --lint` on the workflow, failing on every lint but the ones this project declines.

    .venv/bin/python scripts/lint_workflow.py

Snakemake's linter exits non-zero on any lint and has no option to leave one out, and one of its
lints asks for what this project does not do by design: a conda environment or a container per
rule. Every rule runs in the one virtual environment that `constraints.txt` pins (the README's
two commands, "nothing else needed"), and its provenance sidecars record the package versions.
So this runs the linter, prints every lint, and exits non-zero when a lint other than those of
:data:`DECLINED` is left, or when the linter itself fails (a workflow that does not parse).
"""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

#: the lints this project declines, by title, each with its reason
DECLINED = {
    "Specify a conda environment or container for each rule.": (
        "one pinned virtual environment for every rule (constraints.txt)"
    ),
}

#: "Lints for rule simulate (line 9, …/acquire.smk):" or "Lints for snakefile …/common.smk:"
HEADING = re.compile(r"^Lints for (?P<item>.+):$")
#: "    * Mixed rules and functions in same snakefile.:"
TITLE = re.compile(r"^    \* (?P<title>.+):$")


def lints(text: str) -> list[tuple[str, str]]:
    """(item, title) of every lint in the text `snakemake --lint` prints."""
    found, item = [], None
    for line in text.splitlines():
        if heading := HEADING.match(line):
            item = heading["item"]
        elif (title := TITLE.match(line)) and item is not None:
            found.append((item, title["title"]))
    return found


def verdict(returncode: int, text: str) -> tuple[list[tuple[str, str]], str | None]:
    """The lints that fail the check, and why the linter's run fails otherwise (None: it ran)."""
    found = lints(text)
    if returncode != 0 and not found:
        return [], f"snakemake --lint failed without a lint (exit {returncode})"
    return [(item, title) for item, title in found if title not in DECLINED], None


def main(root: Path = Path(__file__).resolve().parents[1]) -> int:
    run = subprocess.run(
        [sys.executable, "-m", "snakemake", "--lint"],
        cwd=root,
        capture_output=True,
        text=True,
    )
    text = run.stdout + run.stderr
    left, failed = verdict(run.returncode, text)
    if failed:
        print(text[-3000:], file=sys.stderr)
        print(failed, file=sys.stderr)
        return 1
    for item, title in left:
        print(f"{item}: {title}")
    declined = [title for _, title in lints(text) if title in DECLINED]
    for title, reason in DECLINED.items():
        print(f"declined {declined.count(title)} times: {title!r} ({reason})")
    print(f"snakemake --lint: {len(left)} lints to fix", end="")
    print(" (what each asks: .venv/bin/snakemake --lint)" if left else "")
    return 1 if left else 0


if __name__ == "__main__":
    sys.exit(main())
