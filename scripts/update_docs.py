"""Write the scorecard's numbers into the README and docs/deviations.md, and keep the summary they
come from under docs/snapshot/ (so a clone shows them before its first run, and a test checks the
pages against it). Run after the thesis campaign: .venv/bin/python scripts/update_docs.py
"""

import argparse
import json
import shutil
from pathlib import Path

import pandas as pd

from selfsense.scorecard.render import counts_markdown, deviations_markdown, replace_block

SNAPSHOT = Path("docs/snapshot")
PAGES = {"counts": Path("README.md"), "deviations": Path("docs/deviations.md")}


def render(snapshot: Path = SNAPSHOT) -> dict[str, str]:
    """The generated blocks, from the snapshot of the summary and the scorecards."""
    counts = pd.read_csv(snapshot / "scorecard_counts.csv")
    campaign = json.loads((snapshot / "campaign.json").read_text())["campaign"]
    cards = {
        p.stem.removeprefix("scorecard_"): pd.read_csv(p)
        for p in sorted(snapshot.glob("scorecard_*.csv"))
        if p.name != "scorecard_counts.csv"
    }
    return {"counts": counts_markdown(counts, campaign), "deviations": deviations_markdown(cards)}


def main(results: Path, snapshot: Path = SNAPSHOT):
    snapshot.mkdir(exist_ok=True)
    shutil.copy(results / "scorecard_counts.csv", snapshot / "scorecard_counts.csv")
    for card in sorted(results.glob("*/scorecard.csv")):
        shutil.copy(card, snapshot / f"scorecard_{card.parent.name}.csv")
    sidecar = json.loads((results / "scorecard_counts.csv.json").read_text())
    (snapshot / "campaign.json").write_text(
        json.dumps(
            {"campaign": sidecar["config"]["campaign"], "code": sidecar["code"]["git_describe"]},
            indent=1,
        )
        + "\n"
    )
    for name, body in render(snapshot).items():
        PAGES[name].write_text(
            replace_block(PAGES[name].read_text(encoding="utf-8"), name, body), encoding="utf-8"
        )


if __name__ == "__main__":
    cli = argparse.ArgumentParser(description=__doc__)
    cli.add_argument("--results", type=Path, default=Path("results"))
    main(cli.parse_args().results)
