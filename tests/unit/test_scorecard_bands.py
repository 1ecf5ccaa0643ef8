"""The registry's bands mean what their justifications say: one rule per kind of quantity, applied
uniformly (workflow/scorecard.yaml, `bands:`)."""

import math
import re

import pytest

from selfsense.io.manifest import load_yaml
from selfsense.scorecard.calibration import load_targets
from selfsense.scorecard.registry import last_digit, parse_registry
from selfsense.scorecard.scoring import band

from ..helpers import ROOT

REGISTRY = ROOT / "workflow" / "scorecard.yaml"


@pytest.fixture(scope="module")
def registry():
    return parse_registry(load_yaml(REGISTRY), str(REGISTRY))


@pytest.fixture(scope="module")
def rules():
    return {b["name"]: b for b in load_yaml(REGISTRY)["bands"].values()}


def numbers(registry, *, where):
    return [e for e in registry if where(e)]


def test_no_positive_quantity_gets_a_band_reaching_zero_or_below(registry):
    """A position error of 0.42 µm cannot be compared as 0.42 ± 0.6 µm: the band would admit an
    error of zero or below. Stated bounds ("< 3 %") are open on one side by nature."""
    bad = [
        (e.source, e.quantity, band(e.published, e))
        for e in registry
        if e.published is not None
        and e.published > 0
        and e.tolerance is not None
        and not e.bound
        and band(e.published, e)[0] <= 0
    ]
    assert not bad


def test_goodness_of_fit_is_compared_on_one_minus_r2(registry):
    fits = numbers(registry, where=lambda e: "R²" in e.quantity)
    assert len(fits) == 17 and {e.band.name for e in fits} == {"goodness of fit"}
    for e in fits:  # a factor of two on the unexplained share, as the justification says
        lo, hi = band(e.published, e)
        assert (1 - lo) / (1 - e.published) == pytest.approx(2) and (1 - e.published) / (
            1 - hi
        ) == pytest.approx(2)


def test_ill_conditioned_coefficients_get_no_verdict_and_the_curves_are_compared(registry):
    coefficient = re.compile(r"^(t Stat of )?bT?[0-5]$")
    rows = numbers(registry, where=lambda e: coefficient.match(e.quantity))
    assert len(rows) == 24 and all(e.tolerance is None and e.locate for e in rows)
    curves = numbers(
        registry, where=lambda e: e.band.name == "fitted curve against the printed one"
    )
    assert {e.source for e in curves} == {
        "Table 5.2, the fitted curve",
        "Table 7.3, the fitted curve",
    }
    assert all(e.locate and e.kind == "emergent" for e in curves)


@pytest.mark.parametrize(
    "rule, unit, pattern",
    [
        ("position error", "µm", r"error|ε"),
        ("error in % of stroke", "%", r"(error|ε).*% of stroke"),
        ("temperature error", "K", r"temperature error"),
    ],
)
def test_errors_are_held_to_their_instruments_rule(registry, rule, unit, pattern):
    """Every error of its kind uses the one rule, or the source's own stated bound."""
    errors = numbers(
        registry,
        where=lambda e: (
            e.unit == unit
            and re.search(pattern, e.quantity)
            and "standard error" not in e.quantity
            and not e.quantity.startswith("σ")
        ),
    )
    assert errors and {e.band.name for e in errors} <= {rule, "stated bound"}
    assert any(e.band.name == rule for e in errors)


def test_closed_forms_are_held_to_half_a_unit_of_the_last_printed_digit(registry):
    for e in numbers(registry, where=lambda e: e.band.name == "closed form"):
        lo, hi = band(e.published, e)
        assert hi - lo == pytest.approx(last_digit(e.printed or repr(e.published)))
        assert e.kind == "closed form"


def test_every_rule_is_used_and_every_own_band_is_for_one_reason(registry, rules):
    used = {e.band.name for e in registry}
    assert set(rules) <= used, set(rules) - used
    own = {e.band for e in registry if e.band.name not in rules}
    assert len(own) == len(
        {b.name for b in own}
    )  # a band of its own is not a rule applied unevenly


def test_only_emergent_numbers_are_counted_as_reproductions(registry):
    """Numbers that hold by construction are labelled so: every closed-form band is of a closed
    form, the twin's inputs are recovery, and every number a calibration signature of the twin
    reads (workflow/twin_calibration.yaml) is calibration, with the strokes and k/α they set."""
    assert {e.kind for e in registry if e.band.name in ("twin input", "model on truth")} == {
        "recovery"
    }
    assert {e.band.name for e in registry if e.centre} == {"model on truth"}
    calibration = {e.locate for e in registry if e.kind == "calibration" and e.model == "stack"}
    signatures = {
        t.locate for t in load_targets(ROOT / "workflow" / "twin_calibration.yaml").targets
    }
    assert signatures <= calibration, signatures - calibration
    stack = [e for e in registry if e.model == "stack"]
    assert {
        e.kind for e in stack if e.source == "Table 5.4" and e.quantity.startswith("max stroke")
    } == {"calibration"}
    assert {e.kind for e in stack if e.quantity == "k/α"} == {"calibration"}
    # the bender twin's manifest sets its hysteresis and creep to the open-loop voltage results
    assert {
        e.kind
        for e in registry
        if e.model == "bender" and "open-loop voltage control" in e.quantity
    } == {"calibration"}
    assert all(e.section == "twin recovery" or e.published is not None for e in registry)
    assert not [e for e in registry if e.section == "twin recovery" and e.kind != "recovery"]


def test_the_bounds_of_the_rules_are_finite_where_a_value_is_compared(registry):
    for e in registry:
        if e.tolerance is not None and not e.bound and e.published is not None:
            assert all(math.isfinite(x) for x in band(e.published, e)), (e.source, e.quantity)


def test_the_documented_bands_are_the_registrys(rules):
    """docs/scorecard.md states each rule's band (the recovery rows' ±2 % among them): the text
    must be the registry's, so what a reader is told is what the scorecard applies."""
    table = {}
    for line in (ROOT / "docs" / "scorecard.md").read_text(encoding="utf-8").splitlines():
        cells = [c.strip() for c in line.strip("|").split("|")]
        if line.startswith("| ") and len(cells) == 2:
            for name in cells[0].split(", "):
                table[name] = cells[1]
    for name, rule in rules.items():
        tol = rule.get("tolerance", {})
        if "rel" in tol:
            assert f"±{tol['rel']:g} %" in table[name], name
        elif "abs" in tol and tol.get("scale") == "log":
            assert f"up to {tol['abs']:g}" in table[name], name
        elif "factor" in tol:
            assert f"factor of {tol['factor']:g}" in table[name], name


def test_every_band_centred_on_the_model_on_truth_holds_its_centre_to_the_twin_input_rule(
    registry, rules
):
    """The model's bias (docs/scorecard.md, "The model's bias"): a recovery number centred on the
    model on the twin's truth has a second verdict, that centre against the built value, by the
    same rule as a recovery number of a model that fits the twin (±2 % of the built value)."""
    twin_input = rules["twin input"]
    centred = [e for e in registry if e.centre or e.built]
    assert {e.band.name for e in centred} == {"model on truth"} and len(centred) == 10
    for e in centred:
        assert e.band.bias.name == twin_input["name"]
        assert e.band.bias.tolerance.rel == twin_input["tolerance"]["rel"] == 2
    assert [e for e in registry if e.band.bias] == centred
    g = [e for e in centred if e.source == "Table 7.3"]
    assert [e.quantity for e in g] == ["g (temperature coefficient)"] and g[0].published == 0.263115


def test_numbers_that_hold_by_construction_are_checks(registry):
    """One-sided bounds an idealised twin always meets, and numbers the twin's model shares with
    the analysis, are of kind check, not emergent (docs/scorecard.md, "Kinds of numbers")."""
    checks = {(e.source, e.quantity) for e in registry if e.kind == "check"}
    scatter = {(e.source, e.quantity) for e in registry if e.band.name == "scatter"}
    assert len(scatter) == 4 and scatter <= checks
    prediction = {
        (e.source, e.quantity)
        for e in registry
        if e.source == "Chapter 7 results, temperature prediction"
    }
    assert len(prediction) == 3 and prediction <= checks
    assert ("Table 5.2", "significance F") in checks
    assert checks == scatter | prediction | {("Table 5.2", "significance F")}
    # the mixed run's two-sided temperature errors can fail either way: emergent
    mixed = [e for e in registry if e.source == "Chapter 7 results, mixed-frequency run"]
    assert mixed and {e.kind for e in mixed} == {"emergent"}


def test_numbers_that_follow_a_calibration_name_it(registry):
    """Γ's residuals (Tables 5.1, 5.2) follow the calibrated C_e–x loop without being its
    signature: emergent, with the signature named; P3's open-loop creep is what the twin's hand-set
    creep elements were chosen to meet: calibration, naming the unknowns that declare them."""
    ids = {t.id for t in load_targets(ROOT / "workflow" / "twin_calibration.yaml").targets}
    assert "ce_x_loop" in ids
    residuals = [
        e
        for e in registry
        if e.source == "Table 5.1"
        or (e.source == "Table 5.2" and e.quantity in ("residual SS", "residual MS"))
    ]
    assert len(residuals) == 16
    for e in residuals:
        assert e.kind == "emergent" and "ce_x_loop" in e.note, e.quantity
    (creep,) = [e for e in registry if e.quantity == "P3, open-loop creep"]
    assert creep.kind == "calibration"
    unknowns = {u["id"]: u for u in load_yaml(ROOT / "workflow" / "unknowns.yaml")["unknowns"]}
    for name in ("creep_c_fast", "creep_c_slow", "creep_tau_fast", "creep_tau_slow"):
        assert name in creep.note and "Table 6.2 P3" in unknowns[name]["affects"], name
