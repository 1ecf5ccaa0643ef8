"""The numbers the README and docs/deviations.md quote are the scorecard's, written by
scripts/update_docs.py from the snapshot docs/snapshot/, never typed by hand."""

import pandas as pd

from selfsense.scorecard.render import BEGIN, END, summary

from ..helpers import ROOT, load_module


def update_docs():
    return load_module(ROOT / "scripts" / "update_docs.py")


def block(page: str, name: str) -> str:
    text = (ROOT / page).read_text(encoding="utf-8")
    return text.split(BEGIN.format(name=name) + "\n")[1].split("\n" + END.format(name=name))[0]


def test_the_pages_quote_the_snapshot_exactly():
    module = update_docs()
    rendered = module.render(ROOT / "docs" / "snapshot")
    for name, page in module.PAGES.items():
        assert block(str(page), name) == rendered[name], f"{page}: run scripts/update_docs.py"


def test_the_snapshot_counts_are_the_snapshot_scorecards_counts():
    snapshot = ROOT / "docs" / "snapshot"
    cards = {
        p.stem.removeprefix("scorecard_"): pd.read_csv(p)
        for p in sorted(snapshot.glob("scorecard_*.csv"))
        if p.name != "scorecard_counts.csv"
    }
    counts = pd.read_csv(snapshot / "scorecard_counts.csv")
    expected = summary(cards)
    pd.testing.assert_frame_equal(
        counts.astype({"chapter": str}), expected.astype({"chapter": str}), check_dtype=False
    )
