"""The validation's numbers as the README and docs/validation.md quote them: a row and its
algebraic twins counted once, a row no run gave a value said to be not run, the pseudo-theses'
coverage computed from their PIT table, the incompatible folds named."""

import pandas as pd

from selfsense.envelope.render import (
    ValidationSnapshot,
    VariantSnapshot,
    coverage_sentence,
    validation_markdown,
    validation_rows_markdown,
    variant_rows_markdown,
    variants_markdown,
)

VERDICTS = pd.DataFrame(
    {
        "chapter": ["5", "5", "6", "7"],
        "source": ["Table 5.1", "Table 5.1", "Table 6.1", "Table 7.2"],
        "quantity": ["R²", "adjusted R²", "mean ε", "R²"],
        "unit": ["", "", "µm", ""],
        "published": [0.99, 0.99, 0.5, 0.9],
        "p2.5": [0.9, 0.9, 0.9, float("nan")],
        "p97.5": [0.999, 0.999, 2.0, float("nan")],
        "implausibility": [0.2, 0.2, 3.4, float("nan")],
        "verdict": ["consistent", "consistent", "inconsistent", "not emulable"],
        "fold": ["F04", "F04", "F10", "F16"],
        "twin of": ["", "R²", "", ""],
        "driven by": ["a 60 %; noise 5 %", "", "b 30 %; noise 40 %", ""],
        "runs": [30, 30, 30, 0],
    }
)
PIT = pd.DataFrame(
    {"member": ["m1"] * 3 + ["m2"] * 2, "PIT": [0.05, 0.5, 0.95, 0.35, 0.99]}
).assign(**{"inside 95 %": [True, True, True, True, False]})
SNAP = ValidationSnapshot(
    "pi_p885_ch3_6",
    VERDICTS,
    pd.DataFrame({"member": ["m1", "m2"]}),
    PIT,
    {"code": {"git_describe": "abc1234"}, "members": 30, "validation_sha256": "f" * 64},
    {"F04": "the 0.1 Hz capture", "F10": "P1", "F16": "Γ_T"},
)


def test_the_counts_take_a_twin_with_its_row_and_name_what_was_not_run():
    text = validation_markdown([SNAP])
    lines = {line.split(" | ")[0]: line for line in text.splitlines() if line.startswith("| ")}
    columns = lines["| chapter"].strip("| ").split(" | ")
    chapter_5 = dict(zip(columns, lines["| Chapter 5"].strip("| ").split(" | ")))
    assert chapter_5["findings"] == "1" and chapter_5["consistent"] == "1"
    chapter_7 = dict(zip(columns, lines["| Chapter 7"].strip("| ").split(" | ")))
    assert chapter_7["not run"] == "1" and chapter_7["not emulable"] == "0"
    assert "30 runs" in text and "code abc1234" in text


def test_the_coverage_is_the_pit_tables_share_inside():
    sentence = coverage_sentence(PIT, 2)
    assert "4 of 5 held-out rows" in sentence and "80.0%" in sentence
    assert "1 0 0 1 0 1 0 0 0 2." in sentence  # the PIT histogram in tenths


def test_every_inconsistent_finding_is_listed_with_its_fold_and_drivers():
    text = validation_rows_markdown([SNAP])
    assert "1 findings inconsistent" in text
    assert "Table 6.1, mean ε: published 0.5, predicted 0.9 to 2 µm (F10, I = 3.4)" in text
    assert "driven by b 30 %; noise 40 %" in text


def test_the_headline_is_the_latest_test_and_the_earlier_one_is_given_beside():
    both = pd.concat([PIT.assign(test="the twin exact"), PIT.assign(test="with it")])
    both.loc[both["test"] == "with it", "inside 95 %"] = [True, False, False, True, False]
    sentence = coverage_sentence(both, 2)
    assert "test “with it”: 2 of 5 held-out rows" in sentence
    assert "The earlier test, “the twin exact”: 80.0%." in sentence


FOLDS = pd.DataFrame(
    {
        "fold": ["A", "B", "C"],
        "today's twin": ["fails", "fails", "holds"],
        "the term v": ["holds", "holds", "holds"],
        "the term w": ["fails", "holds", "fails"],
    }
)
ROWS = pd.DataFrame(
    {
        "model": ["today's twin", "the term v", "the term w"],
        "fold": ["B"] * 3,
        "source": ["Table 4.2"] * 3,
        "quantity": ["k"] * 3,
        "unit": ["N/µm"] * 3,
        "published": [11.2] * 3,
        "p2.5": [24.0, 9.0, float("nan")],
        "p50": [24.5, 12.0, float("nan")],
        "p97.5": [25.0, 15.0, float("nan")],
        "implausibility": [9.0, 0.1, float("nan")],
        "verdict": ["inconsistent", "consistent", "incompatible"],
    }
)
RECORD = {"code": {"git_describe": "abc1234"}, "members": 40, "validation_sha256": "e" * 64}


def test_a_variant_is_supported_when_it_reconciles_a_fold_and_breaks_none():
    text = variants_markdown([VariantSnapshot("v", FOLDS, ROWS, RECORD)])
    lines = {line.split(" | ")[0]: line for line in text.splitlines() if line.startswith("| ")}
    assert lines["| the term v"].endswith("| 3 | 0 | 0 | A, B | – | yes |")
    assert lines["| the term w"].endswith("| 1 | 2 | 0 | B | C | no |")
    assert "Supported: the term v." in text and "40 runs" in text


def test_the_declared_rows_are_set_side_by_side_under_every_model():
    text = variant_rows_markdown([VariantSnapshot("v", FOLDS, ROWS, RECORD)])
    row = next(line for line in text.splitlines() if line.startswith("| Table 4.2"))
    assert row == (
        "| Table 4.2, k | 11.2 N/µm | inconsistent [24, 25] | consistent [9, 15] | incompatible |"
    )

    assert "Folds today's twin fails: A, B." in text
    assert "- the term v: reconciles A, B, breaks no fold: supported" in text
    assert "- the term w: reconciles B, breaks C: not supported" in text
