"""The validation's declaration (workflow/validation.yaml): the shipped file loads with every
emergent row of the registry in exactly one fold; the loader refuses, in one line naming the file
and the key, a fold or target without a source or a variance, a row in no fold or in two, a fold
naming a row the registry lacks, two folds sharing a capture, an unknown class or signature, a
judged class for a no-verdict row; the hash follows the file's bytes."""

import copy
import hashlib
import math

import pytest
import yaml

from selfsense.envelope.validation import load_validation, validation_hash
from selfsense.io.manifest import ManifestError, load_dataset, load_yaml
from selfsense.scorecard.registry import EMERGENT, applicable, parse_registry

from ..helpers import ROOT

DECLARATION = ROOT / "workflow" / "validation.yaml"


@pytest.fixture(scope="module")
def registry():
    return parse_registry(load_yaml(ROOT / "workflow" / "scorecard.yaml"))


@pytest.fixture(scope="module")
def manifest():
    return load_dataset(ROOT / "raw", "pi_p885")


@pytest.fixture(scope="module")
def declaration(registry, manifest):
    return load_validation(DECLARATION, ROOT, registry, manifest)


@pytest.fixture(scope="module")
def document():
    return load_yaml(DECLARATION)


def refused(tmp_path, doc, registry, manifest):
    """The loader's one-line refusal of ``doc``."""
    path = tmp_path / "validation.yaml"
    path.write_text(yaml.safe_dump(doc, allow_unicode=True, sort_keys=False), encoding="utf-8")
    with pytest.raises(ManifestError) as err:
        load_validation(path, ROOT, registry, manifest)
    message = str(err.value)
    assert "\n" not in message and message.startswith(str(path)), message
    return message


def test_every_emergent_row_is_in_exactly_one_fold(declaration, registry, manifest):
    emergent = {
        (e.source, e.quantity) for e in applicable(registry, manifest) if e.kind == EMERGENT
    }
    keys = [r.key for r in declaration.rows]
    assert len(keys) == len(set(keys)) == len(emergent) == 206
    assert set(keys) == emergent


def test_rows_of_one_capture_share_a_fold(declaration):
    fold_of = {r.key: r.fold for r in declaration.rows}
    # P1's open and closed loops and its summary; Γ's fit with Table 5.4's 0.1 Hz row; a µm row
    # with its % of stroke; R² with adjusted R²
    p1 = fold_of["Table 6.1", "max ε_TOL, segment a"]
    assert fold_of["Chapter 6 results, profile P1", "improvement of closed over open loop"] == p1
    assert fold_of["Table 6.1", "σ ε_OCL, segment h"] == p1
    gamma = fold_of["Table 5.1", "Γ order 5, R²"]
    assert fold_of["Table 5.4", "open-loop max error, 0.1 Hz"] == gamma
    assert fold_of["Table 6.2", "P2b, ε_TOL"] == fold_of["Table 6.2", "P2b, ε_TOL, % of stroke"]
    assert fold_of["Table 7.2", "Γ_T n = 4, R²"] == fold_of["Table 7.2", "Γ_T n = 4, adjusted R²"]
    captures = [c for f in declaration.folds for c in f.captures]
    assert len(captures) == len(set(captures))


def test_rows_on_their_scales(declaration):
    rows = {r.key: r for r in declaration.rows}
    # a bound row asserts the registry's threshold, not the printed 0
    curve = rows["Table 5.2, the fitted curve",
                 "Γ of order 5 against the thesis's, max difference over its C range"]  # fmt: skip
    assert curve.low == -math.inf and curve.high == pytest.approx(math.log(1.5))
    p = rows["Table 7.2", "p of the C·T interaction"]
    assert p.low == pytest.approx(math.log(0.05)) and p.high == math.inf
    # a printed value: both edges at it; its rounding (0.01 µm/√12) carried to the log scale
    e = rows["Table 5.4", "open-loop max error, 50 Hz"]
    assert e.low == e.high == pytest.approx(math.log(0.79))
    assert e.obs_sd == pytest.approx(0.01 / math.sqrt(12) / 0.79)
    r2 = rows["Table 5.1", "Γ order 5, R²"]
    assert r2.transform == "log1m" and r2.low == pytest.approx(math.log(1 - 0.99889))
    # no-verdict coefficients are held out with their fold, neither judged nor conditioned on
    b0 = rows["Table 5.2", "b0"]
    assert not b0.judged and not b0.condition
    assert not rows["Table 6.2", "P2a, ε_OCL, % of stroke"].condition


def test_targets_and_what_each_fold_leaves_out(declaration):
    targets = {t.id: t for t in declaration.targets}
    assert len(targets) >= 10  # the second-maximum rule applies to the waves
    assert targets["df_table_5_2"].low == pytest.approx(math.log(14374))
    sig = targets["sig_tau"]
    assert sig.low == sig.high == 100 and sig.obs_sd == pytest.approx(7.5)  # 85–115 s: ±15 s / 2
    assert targets["p1_loop_works"].low == -math.inf
    assert set(declaration.fold("F10").left_out) == {"p1_loop_works", "p1_no_limit_cycle"}
    assert "df_table_5_2" in declaration.fold("F04").left_out
    assert declaration.fold("F02").left_out == ()


def test_the_hash_follows_the_bytes(tmp_path):
    copy_ = tmp_path / "validation.yaml"
    copy_.write_bytes(DECLARATION.read_bytes() + b"# a comment\n")
    assert validation_hash(DECLARATION) == hashlib.sha256(DECLARATION.read_bytes()).hexdigest()
    assert validation_hash(copy_) != validation_hash(DECLARATION)


# --- refusals -------------------------------------------------------------------------------------


def test_refuses_a_fold_without_a_source_of_its_rows(tmp_path, document, registry, manifest):
    doc = copy.deepcopy(document)
    del doc["folds"][0]["rows"][0]["source"]
    message = refused(tmp_path, doc, registry, manifest)
    assert "folds.0 (F01).rows.0" in message and "'source'" in message


def test_refuses_a_fold_without_its_argument(tmp_path, document, registry, manifest):
    doc = copy.deepcopy(document)
    del doc["folds"][3]["argument"]
    message = refused(tmp_path, doc, registry, manifest)
    assert "folds.3 (F04)" in message and "'argument'" in message


def test_refuses_a_target_without_a_source(tmp_path, document, registry, manifest):
    doc = copy.deepcopy(document)
    del doc["targets"][0]["source"]
    message = refused(tmp_path, doc, registry, manifest)
    assert "targets.0 (df_table_5_2)" in message and "'source'" in message


def test_refuses_a_class_without_a_discrepancy(tmp_path, document, registry, manifest):
    doc = copy.deepcopy(document)
    del doc["classes"]["position_error"]["discrepancy"]
    message = refused(tmp_path, doc, registry, manifest)
    assert "classes.position_error" in message and "'discrepancy'" in message


def test_refuses_a_variance_component_without_a_source(tmp_path, document, registry, manifest):
    doc = copy.deepcopy(document)
    del doc["classes"]["stroke"]["observation"][0]["source"]
    message = refused(tmp_path, doc, registry, manifest)
    assert "classes.stroke.observation.0" in message and "'source'" in message


def test_refuses_a_target_with_no_variance(tmp_path, document, registry, manifest):
    doc = copy.deepcopy(document)
    doc["classes"]["count"]["observation"][0]["sd"] = 0.0
    doc["classes"]["count"]["discrepancy"]["sd"] = 0.0
    message = refused(tmp_path, doc, registry, manifest)
    assert "targets.0 (df_table_5_2)" in message and "no variance" in message


def test_refuses_a_target_in_an_unjudged_class(tmp_path, document, registry, manifest):
    doc = copy.deepcopy(document)
    doc["targets"][1]["class"] = "coefficient"
    message = refused(tmp_path, doc, registry, manifest)
    assert "targets.1 (df_table_7_3).class" in message and "no variance" in message


def test_refuses_a_row_in_no_fold(tmp_path, document, registry, manifest):
    doc = copy.deepcopy(document)
    del doc["folds"][0]  # F01: the U–I phase
    message = refused(tmp_path, doc, registry, manifest)
    assert "U–I phase at 10 Hz" in message and "in no fold" in message


def test_refuses_a_row_in_two_folds(tmp_path, document, registry, manifest):
    doc = copy.deepcopy(document)
    doc["folds"][1]["rows"].append({"source": "Chapter 3 results, Figs 3.3–3.4", "class": "phase"})
    message = refused(tmp_path, doc, registry, manifest)
    assert "folds.1 (F02).rows.1" in message and "also in fold F01" in message


def test_refuses_a_row_the_registry_lacks(tmp_path, document, registry, manifest):
    doc = copy.deepcopy(document)
    doc["folds"][4]["rows"][0]["quantities"] = ["open-loop max error, 0.02 Hz"]
    message = refused(tmp_path, doc, registry, manifest)
    assert "folds.4 (F05).rows.0" in message and "0.02 Hz" in message


def test_refuses_a_source_the_registry_lacks(tmp_path, document, registry, manifest):
    doc = copy.deepcopy(document)
    doc["folds"][0]["rows"][0]["source"] = "Table 9.9"
    message = refused(tmp_path, doc, registry, manifest)
    assert "folds.0 (F01).rows.0" in message and "Table 9.9" in message


def test_refuses_two_folds_on_one_capture(tmp_path, document, registry, manifest):
    doc = copy.deepcopy(document)
    doc["folds"][1]["captures"].append("ch3_sine_10hz")
    message = refused(tmp_path, doc, registry, manifest)
    assert "folds.1 (F02).captures" in message and "also fold F01's" in message


def test_refuses_a_capture_the_protocols_lack(tmp_path, document, registry, manifest):
    doc = copy.deepcopy(document)
    doc["targets"][0]["captures"] = ["ch5_sine_0p2hz"]
    message = refused(tmp_path, doc, registry, manifest)
    assert "targets.0 (df_table_5_2).captures" in message and "ch5_sine_0p2hz" in message


def test_refuses_an_unknown_class_or_signature(tmp_path, document, registry, manifest):
    doc = copy.deepcopy(document)
    doc["folds"][0]["rows"][0]["class"] = "angle"
    assert "no class 'angle'" in refused(tmp_path, doc, registry, manifest)
    doc = copy.deepcopy(document)
    sig = next(i for i, t in enumerate(doc["targets"]) if t["kind"] == "signature")
    doc["targets"][sig]["signature"] = "loop_area"
    assert "no signature 'loop_area'" in refused(tmp_path, doc, registry, manifest)


def test_refuses_a_verdict_the_registry_does_not_give(tmp_path, document, registry, manifest):
    doc = copy.deepcopy(document)
    fold = doc["folds"][3]  # F04: Table 5.2's coefficients have no verdict in the registry
    sel = next(s for s in fold["rows"] if s["class"] == "coefficient")
    sel["class"] = "regression_statistic"
    message = refused(tmp_path, doc, registry, manifest)
    assert "no verdict in the registry" in message and "'b0'" in message


def test_refuses_a_twin_row_without_its_reason(tmp_path, document, registry, manifest):
    doc = copy.deepcopy(document)
    sel = next(s for s in doc["folds"][3]["rows"] if s.get("condition") is False)
    del sel["why"]
    message = refused(tmp_path, doc, registry, manifest)
    assert "folds.3 (F04).rows" in message and "'why'" in message


def test_refuses_a_date_that_is_no_date(tmp_path, document, registry, manifest):
    doc = copy.deepcopy(document)
    doc["date"] = "2026-02-30"
    assert "key date" in refused(tmp_path, doc, registry, manifest)


def test_refuses_a_history_that_does_not_end_at_the_files_version(
    tmp_path, document, registry, manifest
):
    doc = copy.deepcopy(document)
    doc["version"] = doc["history"][-1]["version"] + 1
    message = refused(tmp_path, doc, registry, manifest)
    assert "key history" in message and f"version {doc['version']}" in message
