"""The reviewer's table: each emergent row's posterior beside the nominal scorecard's band and
verdict and the prior envelope's interval and verdict, the envelope that judges a row chosen
among several; the forest draws the judged rows only, each with both intervals."""

import numpy as np
import pandas as pd
import pytest

from selfsense.envelope.figures import plt, review_forest, review_rows
from selfsense.envelope.review import review_table

VERDICTS = pd.DataFrame(
    {
        "chapter": ["5", "5", "7"],
        "source": ["Table 5.1", "Table 5.1", "Table 7.2"],
        "quantity": ["a", "b", "c"],
        "unit": ["µm", "µm", "1"],
        "published": [1.0, 2.0, 0.5],
        "p2.5": [0.8, 2.5, np.nan],
        "p50": [1.0, 3.0, np.nan],
        "p97.5": [1.2, 3.5, np.nan],
        "implausibility": [0.1, 4.2, np.nan],
        "verdict": ["consistent", "inconsistent", "not emulable"],
        "fold": ["F04", "F04", "F16"],
        "twin of": ["", "", ""],
        "driven by": ["x 50 %; noise 10 %", "y 20 %; noise 5 %", ""],
    }
)
NOMINAL = pd.DataFrame(
    {
        "section": ["published", "published", "calibration"],
        "source": ["Table 5.1", "Table 5.1", "Table 7.2"],
        "quantity": ["a", "b", "c"],
        "reproduced": [1.05, 2.9, 0.4],
        "band low": [0.9, 1.8, 0.45],
        "band high": [1.1, 2.2, 0.55],
        "verdict": ["within band", "out of band", "out of band"],
    }
)


def envelope(rows, verdict, low, high):
    return pd.DataFrame(
        {
            "source": [r[0] for r in rows],
            "quantity": [r[1] for r in rows],
            "p2.5": low,
            "p97.5": high,
            "envelope verdict": verdict,
        }
    )


def test_each_row_stands_beside_its_nominal_and_the_envelope_that_judges_it():
    chapters_3_6 = envelope(
        [("Table 5.1", "a"), ("Table 5.1", "b"), ("Table 7.2", "c")],
        ["consistent", "inconsistent", "no envelope"],
        [0.5, 3.0, np.nan],
        [1.5, 4.0, np.nan],
    )
    chapter_7 = envelope([("Table 7.2", "c")], ["inconsistent"], [0.1], [0.2])
    table = review_table(VERDICTS, NOMINAL, [chapters_3_6, chapter_7])
    assert list(table["quantity"]) == ["a", "b", "c"]  # the verdicts' rows, in their order
    assert list(table["nominal verdict"][:2]) == ["within band", "out of band"]
    assert table["band high"].iloc[1] == pytest.approx(2.2)
    assert pd.isna(table["nominal"].iloc[2])  # a calibration row is not the published one
    assert list(table["envelope"]) == ["consistent", "inconsistent", "inconsistent"]
    assert table["envelope p2.5"].iloc[2] == pytest.approx(0.1)  # Chapter 7's own design
    assert list(table["posterior"]) == ["consistent", "inconsistent", "not emulable"]
    assert table["driven by"].iloc[1] == "y 20 %; noise 5 %"


def test_without_a_nominal_or_an_envelope_the_posterior_stands_alone():
    table = review_table(VERDICTS, None, [])
    assert table["nominal"].isna().all()
    assert set(table["envelope"]) == {"no envelope"}
    assert table["posterior p97.5"].iloc[0] == pytest.approx(1.2)


def test_the_forest_draws_the_judged_rows_with_both_intervals():
    chapters_3_6 = envelope(
        [("Table 5.1", "a"), ("Table 5.1", "b")], ["consistent", "inconsistent"], [0.5, 3], [1.5, 4]
    )
    table = review_table(VERDICTS, NOMINAL, [chapters_3_6])
    rows = review_rows(table)
    assert list(rows["label"].str.endswith(("a", "b"))) == [True, True]  # not emulable: not drawn
    assert rows["envelope p2.5"].tolist() == pytest.approx([-50.0, 50.0])
    assert rows["posterior p97.5"].tolist() == pytest.approx([20.0, 75.0])
    fig = review_forest(table, "a $title$")
    try:
        assert len(fig.axes[0].patches) == 4  # two rows, an envelope and a posterior bar each
    finally:
        plt.close(fig)
