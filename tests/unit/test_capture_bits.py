"""The twin's captures held to the bit: short simulated captures of both datasets (the smoke
campaign's runs as the workflow makes them, chunks off the truth's grid, the compiled closed loop)
against the digests of the same captures made at a reference commit, variable by variable, and
the float64 traces they are made from (kernels, time-only signals, the recorder's output), where
a last-bit change shows (tests/data/make_twin_capture_digests.py says which and how). A faster
twin or writer must write the same int16 codes, attributes and /truth, so that every table made
from them stays the same byte for byte."""

import importlib.util
import json

import pytest

from ..helpers import ROOT

SCRIPT = ROOT / "tests" / "data" / "make_twin_capture_digests.py"


def _script():
    spec = importlib.util.spec_from_file_location("make_twin_capture_digests", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_twins_captures_are_the_reference_commits_bit_for_bit(tmp_path):
    module = _script()
    reference = json.loads(module.DIGESTS.read_text())
    if reference["made_on"] != module.platform_key():
        pytest.skip(
            f"the digests were made on {reference['made_on']}, this is {module.platform_key()}: "
            "numpy's cos and libm's differ in the last bit across them"
        )
    made = {case: module.digests(path) for case, path in module.simulate_cases(tmp_path).items()}
    made |= module.float_traces()
    expected = reference["cases"]
    assert sorted(made) == sorted(expected)
    for case, variables in expected.items():
        assert sorted(made[case]) == sorted(variables), case
        differ = [name for name, digest in variables.items() if made[case][name] != digest]
        assert not differ, f"{case}: {', '.join(differ)} differ from the reference"
