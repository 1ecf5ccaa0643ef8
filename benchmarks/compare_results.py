"""Two runs' results against each other: which tables are byte-identical, and for the scorecard
rows that differ whether each stays within its row's tolerance.

    .venv/bin/python benchmarks/compare_results.py BEFORE/results AFTER/results

A speed change that changes a capture's bytes (a new compressor, the compiled closed loop) must
leave every table byte-identical, or the scorecard unchanged within each row's tolerance: the
reproduced value moves by less than half its band (band high − band low) and the verdict stays.
Exits non-zero otherwise. Tables present in only one run are listed.
"""

from __future__ import annotations

import argparse
import csv
import math
import sys
from pathlib import Path

KEY = ("section", "chapter", "source", "quantity")


def rows(path: Path) -> dict[tuple[str, ...], dict[str, str]]:
    with path.open(newline="") as f:
        return {tuple(r[k] for k in KEY): r for r in csv.DictReader(f)}


def number(text: str) -> float:
    try:
        return float(text)
    except ValueError:
        return math.nan


def compare_scorecard(before: Path, after: Path) -> list[str]:
    """The rows of two scorecards that differ beyond their tolerance (or in verdict), as lines."""
    old, new = rows(before), rows(after)
    problems = [
        f"  row only in {'before' if k in old else 'after'}: {k}" for k in old.keys() ^ new.keys()
    ]
    changed = 0
    for key in old.keys() & new.keys():
        a, b = old[key], new[key]
        if a == b:
            continue
        changed += 1
        half = abs(number(a["band high"]) - number(a["band low"])) / 2
        delta = abs(number(b["reproduced"]) - number(a["reproduced"]))
        moved = not (delta <= half) and a["reproduced"] != b["reproduced"]
        if moved or a["verdict"] != b["verdict"]:
            problems.append(
                f"  {key}: {a['reproduced']} → {b['reproduced']} (tolerance ±{half:g}), "
                f"verdict {a['verdict']} → {b['verdict']}"
            )
        else:
            print(f"  within tolerance: {key}: {a['reproduced']} → {b['reproduced']} (±{half:g})")
    print(
        f"  {before.parent.name}/scorecard.csv: {len(old)} rows, {changed} changed, "
        f"{len(problems)} beyond "
        f"tolerance or verdict"
    )
    return problems


def main() -> int:
    cli = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    cli.add_argument("before", type=Path)
    cli.add_argument("after", type=Path)
    args = cli.parse_args()
    tables = sorted(
        {p.relative_to(args.before) for p in args.before.rglob("*.csv")}
        | {p.relative_to(args.after) for p in args.after.rglob("*.csv")}
    )
    same, differ, missing = [], [], []
    for t in tables:
        a, b = args.before / t, args.after / t
        if not (a.exists() and b.exists()):
            missing.append(t)
        elif a.read_bytes() == b.read_bytes():
            same.append(t)
        else:
            differ.append(t)
    print(
        f"{len(tables)} tables: {len(same)} byte-identical, {len(differ)} differ, "
        f"{len(missing)} in one run only"
    )
    for t in differ:
        print(f"  differs: {t}")
    for t in missing:
        print(f"  in one run only: {t}")
    problems = []
    for card in (t for t in differ if t.name == "scorecard.csv"):
        problems += compare_scorecard(args.before / card, args.after / card)
    if (
        missing
    ):  # a run that made fewer tables (or a wrong folder) is no match, whatever its scorecards say
        problems.append(f"  {len(missing)} tables are in one run only")
    print(
        "\n".join(problems)
        if problems
        else "scorecards: every row unchanged or within its tolerance"
    )
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
