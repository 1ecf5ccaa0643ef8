"""The smoke campaign's published numbers are reproduced as before: every emergent row of the
smoke DAG's scorecards within its stated tolerance of tests/data/smoke_scorecard.csv (why that
tolerance, and how to write the file again when a number moves on purpose:
scripts/smoke_scorecard.py)."""

import math

import pytest

from ..helpers import ROOT, load_module


def golden_module():
    return load_module(ROOT / "scripts" / "smoke_scorecard.py")


@pytest.mark.slow
def test_the_smoke_scorecard_reproduces_the_golden_numbers(smoke_run):
    module = golden_module()
    problems = module.moved(module.read(), module.emergent_rows(smoke_run))
    assert not problems, "\n".join(
        [*problems, "moved on purpose? scripts/smoke_scorecard.py TREE writes the file again"]
    )


def test_the_golden_file_holds_every_row_with_its_tolerance():
    module = golden_module()
    golden = module.read()
    assert list(golden.columns) == module.COLUMNS
    assert not golden.duplicated(module.KEY).any()
    assert {"pi_p885", "tokin_nb40"} <= set(golden["dataset"])
    reproduced = golden.dropna(subset=["reproduced"])
    assert len(reproduced) > 100
    for value, tol in zip(reproduced["reproduced"], reproduced["tolerance"], strict=True):
        assert math.isclose(tol, max(module.RTOL * abs(value), module.FLOOR), rel_tol=1e-3)


def test_a_number_that_moves_beyond_its_tolerance_is_named():
    module = golden_module()
    golden = module.read()
    assert module.moved(golden, golden) == []
    row = golden.dropna(subset=["reproduced"]).index[0]
    run = golden.copy()
    # within the tolerance: the same; beyond it, by a part in 10⁵: named with the row
    run.loc[row, "reproduced"] = golden.loc[row, "reproduced"] * (1 + module.RTOL / 2)
    assert module.moved(golden, run) == []
    run.loc[row, "reproduced"] = golden.loc[row, "reproduced"] * (1 + 10 * module.RTOL)
    (problem,) = module.moved(golden, run)
    assert golden.loc[row, "quantity"] in problem
    # a row that is no longer reproduced, or that is gone
    run.loc[row, "reproduced"] = math.nan
    assert len(module.moved(golden, run)) == 1
    assert "only in the golden file" in module.moved(golden, run.drop(index=row))[0]
