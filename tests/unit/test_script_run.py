"""A rule's script called by the rule's names (selfsense.io.provenance.run), with a stand-in for
the object Snakemake gives a script: the same Namedlists."""

import pytest
from snakemake.iocontainers import Namedlist

from selfsense.io.provenance import run


class FakeSnakemake:
    def __init__(self, input, output, params, log=("logs/d/r.log",)):
        self.rule = "some_rule"
        self.input, self.output = _named(input), _named(output)
        self.params, self.log = Namedlist(fromdict=params), Namedlist(list(log))


def _named(files):
    """A Namedlist as Snakemake builds one: a list input is a slice of the flat list."""
    flat = Namedlist()
    for name, value in files.items():
        start = len(flat)
        flat.extend([value] if isinstance(value, str) else value)
        flat._set_name(name, start, None if isinstance(value, str) else len(flat))
    return flat


RULE = {
    "input": {
        "capture": "raw/d/c.nc",
        "series": ["results/d/a.nc", "results/d/b.nc"],
        "qc": ["results/d/qc/c.json"],
        "library": ["src/selfsense/x.py"],
    },
    "output": {"table": "results/d/t.csv", "figure": "figures/d/f.png"},
    "params": {"n_periods": 4, "series_of": {"a": "results/d/a.nc", "b": "results/d/b.nc"}},
}


def test_main_gets_the_rules_names_and_the_provenance_inputs_without_the_library(tmp_path):
    def main(capture, series_of, table, figure, n_periods, inputs, log=None):
        return locals()

    assert run(main, FakeSnakemake(**RULE, log=[str(tmp_path / "r.log")])) == {
        "capture": "raw/d/c.nc",
        "series_of": RULE["params"]["series_of"],
        "table": "results/d/t.csv",
        "figure": "figures/d/f.png",
        "n_periods": 4,
        "inputs": ["raw/d/c.nc", "results/d/a.nc", "results/d/b.nc", "results/d/qc/c.json"],
        "log": str(tmp_path / "r.log"),
    }


def test_outputs_and_params_main_does_not_name_reach_its_keywords_and_unread_inputs_do_not():
    def main(capture, log, **out):
        return out

    assert set(run(main, FakeSnakemake(**RULE))) == {"table", "figure", "n_periods", "series_of"}


def one_line(main, rule, tmp_path):
    with pytest.raises(TypeError) as e:
        run(main, FakeSnakemake(**rule, log=[str(tmp_path / "r.log")]))
    assert "\n" not in str(e.value) and str(e.value).startswith("rule some_rule: ")
    return str(e.value)


def test_a_name_main_needs_and_the_rule_lacks_is_one_line_naming_it(tmp_path):
    def main(capture, series, table, figure, n_periods, frequency, log=None):
        raise AssertionError("not called")

    assert "'frequency'" in one_line(main, RULE, tmp_path)


def test_a_name_the_rule_gives_twice_is_one_line_naming_it(tmp_path):
    twice = RULE | {"params": RULE["params"] | {"capture": "raw/d/other.nc"}}
    why = one_line(lambda **kw: None, twice, tmp_path)
    assert why == "rule some_rule: 'capture' is both an input and a param"


def test_a_param_main_does_not_take_is_one_line_naming_it(tmp_path):
    def main(capture, table, figure, series_of, log):
        raise AssertionError("not called")

    assert "'n_periods' is a param but no parameter of main" in one_line(main, RULE, tmp_path)
