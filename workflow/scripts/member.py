"""Rule `member`: one member of the envelope or the validation in one process
(selfsense.envelope.member): its rules' jobs run in order, keeping what is read of it."""

import json
from pathlib import Path

from selfsense.envelope.member import Step, run_member
from selfsense.io.provenance import run, script_logging


def main(steps, manifest, keep, failure, folder, log=None):
    """steps: its group's steps (rule member_steps); manifest: the member's, whose folder names
    it; keep: its files that are read, under results/<member>/; failure: the file of the folder
    a failed step is noted in (a validation member's), or None (a failed step fails the job);
    folder: where they go."""
    logger = script_logging(log)
    member = Path(manifest).parent.name
    planned = [Step.from_record(r) for r in json.loads(Path(steps).read_text())[member]]
    Path(folder).mkdir(parents=True, exist_ok=True)
    kept = {f"results/{member}/{r}": Path(folder) / r for r in keep}
    failed = run_member(planned, kept, member, failure and Path(folder) / failure)
    logger.info("%s: %d steps, %d files kept in %s", member, len(planned), len(keep), folder)
    if failed:
        logger.warning("%s gave no value: %s", member, failed)


if "snakemake" in globals():
    run(main, snakemake)
