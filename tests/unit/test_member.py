"""The in-process member's plumbing (selfsense.envelope.member): the lean order keeps every step
after what makes its inputs and reads each capture before the next is simulated; a step is its
JSON record again; a scratch folder is removed, and so are those of processes that are gone."""

import os
import subprocess
import sys

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from selfsense.envelope import member
from selfsense.envelope.member import Step, lean_order, scratch_folder


def step(rule, inputs=(), outputs=()):
    return Step(rule, "s.py", (("x", list(inputs)),), (("y", list(outputs)),), (), ())


def test_each_capture_is_read_before_the_next_is_simulated():
    steps = [
        step("sim_a", ["manifest"], ["a.nc"]),
        step("sim_b", ["manifest"], ["b.nc"]),
        step("ex_a", ["a.nc"], ["a.csv"]),
        step("ex_b", ["b.nc"], ["b.csv"]),
        step("card", ["a.csv", "b.csv"], ["card.csv"]),
    ]
    assert [s.rule for s in lean_order(steps)] == ["sim_a", "ex_a", "sim_b", "ex_b", "card"]


def test_a_capture_whose_reader_waits_on_another_is_simulated_after_it():
    # the Chapter 7 capture's reader needs the identification of the Chapter 4 capture: simulated
    # first, the long capture would wait in the scratch while the other is simulated and read
    steps = [
        step("sim_long", ["manifest"], ["long.nc"]),
        step("sim_id", ["manifest"], ["id.nc"]),
        step("identify", ["id.nc"], ["model.json"]),
        step("ex_long", ["long.nc", "model.json"], ["long.csv"]),
        step("card", ["long.csv"], ["card.csv"]),
    ]
    order = [s.rule for s in lean_order(steps)]
    assert order == ["sim_id", "identify", "sim_long", "ex_long", "card"]


@st.composite
def dags(draw):
    """Steps in a topological order, each reading some earlier steps' outputs and sources."""
    n = draw(st.integers(1, 12))
    steps = []
    for i in range(n):
        reads = draw(st.sets(st.integers(0, i - 1), max_size=3)) if i else set()
        steps.append(step(f"r{i}", ["source", *(f"f{j}" for j in sorted(reads))], [f"f{i}"]))
    return draw(st.permutations(steps)), steps


@given(dags())
@settings(max_examples=200, deadline=None)
def test_the_lean_order_keeps_every_step_after_what_it_reads(drawn):
    shuffled, steps = drawn
    ordered = [s for s in lean_order(steps)]
    assert sorted(s.rule for s in ordered) == sorted(s.rule for s in shuffled)
    seen: set[str] = set()
    for s in ordered:
        assert {f for f in s.files("input") if f != "source"} <= seen
        seen |= set(s.files("output"))


def test_a_step_is_its_record_again():
    s = Step(
        "simulate",
        "/x/simulate.py",
        (("manifest", "m.yaml"),),
        (("capture", ["a", "b"]),),
        (("campaign", "thesis"),),
        ("log",),
    )
    assert Step.from_record(s.record()) == s


def test_a_scratch_folder_goes_and_so_do_those_of_processes_that_are_gone(tmp_path, monkeypatch):
    monkeypatch.setenv("TMPDIR", str(tmp_path))
    monkeypatch.setattr(member.tempfile, "tempdir", None)  # re-read TMPDIR
    gone = subprocess.run(
        [sys.executable, "-c", "import os; print(os.getpid())"],
        capture_output=True,
        text=True,
        check=True,
    ).stdout.strip()
    stale = tmp_path / f"{member.SCRATCH_PREFIX}.{gone}.m.abc"
    mine = tmp_path / f"{member.SCRATCH_PREFIX}.{os.getpid()}.m.def"
    stale.mkdir()
    mine.mkdir()
    with scratch_folder("m") as folder:
        assert folder.parent == tmp_path and folder.is_dir()
        (folder / "a.nc").write_bytes(b"x")
        assert not stale.exists() and mine.exists()
    assert not folder.exists()


FAILING_SCRIPT = """
def main(y, inputs, log=None):
    raise ValueError("HPOGains.a0 must be finite and > 0, got -2.2")
"""


def test_a_failed_step_stops_the_member_or_is_noted_in_its_folder(tmp_path):
    """An envelope member's failed step fails its job in one line naming the rule; a validation
    member's (``failure`` given) is noted in its folder in that line, and nothing is kept."""
    script = tmp_path / "bad.py"
    script.write_text(FAILING_SCRIPT)
    steps = [Step("charge_sensing", str(script), (), (("y", ["results/m/t.csv"]),), (), ())]
    kept = {"results/m/t.csv": tmp_path / "t.csv"}
    with pytest.raises(member.StepFailed, match=r"rule charge_sensing \(results/m/t.csv\): .*a0"):
        member.run_member(steps, kept, "m~1")
    note = tmp_path / "failed.txt"
    reason = member.run_member(steps, kept, "m~1", note)
    assert reason.startswith("rule charge_sensing (results/m/t.csv): ")
    assert "HPOGains.a0 must be finite" in reason
    assert note.read_text().strip() == reason
    assert not (tmp_path / "t.csv").exists()
