"""Rule `envelope_member`: one envelope member's manifest, raw/<member>/dataset.yaml (the
envelope dataset's with the member's draws: selfsense.envelope.design.member_manifest, made when
the workflow is parsed and passed here as the rule's param)."""

from selfsense.envelope.design import write_member_manifest
from selfsense.io.provenance import run, script_logging


def main(member, manifest, log=None):
    """member: the member's manifest document; manifest: where it goes."""
    logger = script_logging(log)
    write_member_manifest(dict(member), manifest)
    logger.info(
        "wrote %s (%d protocol overrides)", manifest, len(member.get("protocol_overrides", {}))
    )


if "snakemake" in globals():
    run(main, snakemake)
