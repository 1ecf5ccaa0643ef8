"""Rule `envelope_member`: one envelope member's manifest, raw/<member>/dataset.yaml (the
envelope dataset's with the member's draws: selfsense.envelope.design.member_manifest, made when
the workflow is parsed and passed here as the rule's param)."""

from selfsense.envelope.design import write_member_manifest
from selfsense.io.provenance import script_logging


def main(manifest, output, log=None):
    logger = script_logging(log)
    write_member_manifest(manifest, output)
    logger.info(
        "wrote %s (%d protocol overrides)", output, len(manifest.get("protocol_overrides", {}))
    )


if "snakemake" in globals():
    main(dict(snakemake.params.manifest), snakemake.output.manifest, snakemake.log[0])
