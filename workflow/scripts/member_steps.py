"""Rule `member_steps`: a group's members as steps (selfsense.envelope.member.member_steps), the
jobs Snakemake would run for each member's results, as JSON for rule `member`."""

from selfsense.envelope.member import member_steps
from selfsense.io.provenance import run, script_logging, write_json


def main(snakefile, results, manifests, run_config, steps, log=None):
    """results: {member: the files of it that are read}; manifests: the members' manifests
    (made by rule envelope_member, inputs of each member's job); run_config: this run's config."""
    logger = script_logging(log)
    planned = member_steps(snakefile, results, run_config, given=manifests)
    write_json({m: [s.record() for s in planned[m]] for m in planned}, steps)
    for member, member_steps_ in planned.items():
        logger.info("%s: %d steps", member, len(member_steps_))


if "snakemake" in globals():
    run(main, snakemake)
