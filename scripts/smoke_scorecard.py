"""The golden smoke scorecard, tests/data/smoke_scorecard.csv: every emergent row of the smoke
campaign's scorecards (the published numbers the analyses reproduce), its reproduced value and
the tolerance within which a run must give it again (tests/workflow/test_smoke_scorecard.py).

    .venv/bin/python scripts/smoke_scorecard.py TREE            # write it from a smoke run
    .venv/bin/python scripts/smoke_scorecard.py TREE --check    # compare a smoke run with it

TREE is a checkout where `snakemake --cores 2 --configfile tests/config/smoke.yaml` ran to its
end. When a reproduced number moves on purpose, write the file again from such a run and commit
it with the change: the moved numbers are its diff.

The tolerance. The smoke DAG is deterministic: the same config and seeds make the same captures
to the bit, and the same code the same tables, so on one machine a run gives every number again
exactly. What may differ on another machine is floating point: another BLAS kernel, FMA
contraction or SIMD width rounds differently (tests/tolerances.py), by about N·κ·ε, which the
fits and filters between a capture and a row amplify to well below 1e-9 relative. The scorecard
prints 10 significant digits (a rounding of 5e-10 relative). A row's tolerance is
:data:`RTOL` = 1e-6 of its value: a thousand times the printing's rounding and the expected
cross-machine difference, and at least a hundred times narrower than any row's band (the
narrowest, a closed form's half unit of the last printed digit, is ≈ 1e-4 relative). A value of
zero gets the absolute :data:`FLOOR` in its unit. A move the tolerance lets through cannot change
a verdict; one it refuses is a change of the analysis, not of the machine.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import pandas as pd

GOLDEN = Path(__file__).resolve().parents[1] / "tests" / "data" / "smoke_scorecard.csv"
#: a row: its dataset and the scorecard's key (benchmarks/compare_results.py's)
KEY = ["dataset", "section", "chapter", "source", "quantity"]
COLUMNS = [*KEY, "unit", "reproduced", "tolerance"]
#: the tolerance relative to the reproduced value, and the absolute one of a value of zero
RTOL, FLOOR = 1e-6, 1e-12


def emergent_rows(tree: Path) -> pd.DataFrame:
    """The emergent rows of every nominal dataset's scorecard under ``tree``/results (an envelope
    member's, ``<dataset>~NN``, is none), with their tolerance."""
    parts = []
    for card in sorted((tree / "results").glob("*/scorecard.csv")):
        if "~" in card.parent.name:
            continue
        rows = pd.read_csv(card, dtype={"chapter": str}, keep_default_na=False)
        rows = rows[rows["kind"] == "emergent"].assign(dataset=card.parent.name)
        parts.append(rows)
    rows = pd.concat(parts, ignore_index=True)
    rows["reproduced"] = pd.to_numeric(rows["reproduced"], errors="coerce")
    rows["tolerance"] = [tolerance(v) for v in rows["reproduced"]]
    return rows[COLUMNS]


def tolerance(value: float) -> float:
    return math.nan if math.isnan(value) else max(RTOL * abs(value), FLOOR)


def write(tree: Path, golden: Path = GOLDEN) -> None:
    rows = emergent_rows(tree)
    rows.to_csv(golden, index=False, float_format="%.10g")


def read(golden: Path = GOLDEN) -> pd.DataFrame:
    rows = pd.read_csv(golden, dtype={"chapter": str}, keep_default_na=False)
    for column in ("reproduced", "tolerance"):
        rows[column] = pd.to_numeric(rows[column], errors="coerce")
    return rows


def moved(golden: pd.DataFrame, run: pd.DataFrame) -> list[str]:
    """The rows of ``run`` not within their golden tolerance, one line each: a number moved, a
    row reproduced in one and not the other, a row in one only."""
    old = golden.set_index(KEY)
    new = run.set_index(KEY)
    problems = [f"only in the golden file: {k}" for k in old.index.difference(new.index)]
    problems += [f"not in the golden file: {k}" for k in new.index.difference(old.index)]
    for key in old.index.intersection(new.index):
        a, b, tol = old.at[key, "reproduced"], new.at[key, "reproduced"], old.at[key, "tolerance"]
        if math.isnan(a) and math.isnan(b):
            continue
        if math.isnan(a) or math.isnan(b) or not abs(b - a) <= tol:
            unit = old.at[key, "unit"]
            problems.append(f"{key}: {float(a)!r} → {float(b)!r} (tolerance ±{tol:.3g} {unit})")
    return problems


def main() -> int:
    cli = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    cli.add_argument("tree", type=Path, help="a checkout where the smoke DAG ran to its end")
    cli.add_argument("--check", action="store_true", help="compare instead of writing")
    args = cli.parse_args()
    if not args.check:
        write(args.tree)
        print(f"wrote {GOLDEN}")
        return 0
    problems = moved(read(), emergent_rows(args.tree))
    print("\n".join(problems) or "every emergent number within its tolerance")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
