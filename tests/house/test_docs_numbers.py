"""The numbers the README and docs/deviations.md quote are the scorecard's, written by
scripts/update_docs.py from the snapshot docs/snapshot/, never typed by hand."""

import json

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


def test_an_envelope_design_is_snapshot_in_a_folder_of_its_name(tmp_path):
    module = update_docs()
    run = tmp_path / "results" / "envelope" / "pi_p885_ch7"
    run.mkdir(parents=True)
    for name in module.ENVELOPE_FILES:
        (run / name).write_text(name)
    design = {"dataset": "pi_p885", "name": "pi_p885_ch7", "chapters": ["7"], "members": 8}
    design |= {"method": "morris", "seed": 1, "levels": 4, "groups": ["thermal"], "stages": []}
    sidecar = {"code": {"git_describe": "abc1234"}, "unknowns_sha256": "0" * 64}
    sidecar |= {"design": design, "members": ["pi_p885_ch7~01"], "calibration_misses": 1}
    (run / "scorecard.csv.json").write_text(json.dumps(sidecar))
    (run / "plan.csv.json").write_text(json.dumps({"varied": ["a"], "held": ["b"]}))
    # the member was made by an earlier commit than the verdicts
    member = tmp_path / "results" / "pi_p885_ch7~01"
    member.mkdir()
    (member / "scorecard.csv.json").write_text(json.dumps({"code": {"git_describe": "0ab0ab0"}}))
    snapshot = tmp_path / "snapshot"
    snapshot.mkdir()
    (snapshot / "campaign.json").write_text(json.dumps({"campaign": "thesis"}))
    module.snapshot_envelope(run, snapshot, 12.5)
    target = snapshot / "envelope" / "pi_p885_ch7"
    assert sorted(p.name for p in target.iterdir()) == sorted(
        [*module.ENVELOPE_FILES, "provenance.json"]
    )
    record = json.loads((target / "provenance.json").read_text())
    assert record["code"] == "abc1234" and record["design"] == design and record["wall_s"] == 12.5
    assert record["members_code"] == ["0ab0ab0"] and record["calibration_misses"] == 1
    columns = ["chapter", "source", "quantity", "envelope verdict", "verdict"]
    line = module.envelope_markdown(
        [(pd.DataFrame(columns=columns), module.Design(**record["design"]), record)]
    )
    assert "code abc1234 (its members 0ab0ab0)" in line
