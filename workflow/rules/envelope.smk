# The reproduction envelope (docs/envelope.md): the twin across the declared range of what the
# sources leave open (workflow/unknowns.yaml). Not part of rule all: `snakemake envelope`. The
# members, <dataset>~NN (ENVELOPE in common.smk), are datasets run by the same rules as the
# nominal one; here only what makes them and what reads them all. These three are local rules:
# they take seconds, and on a cluster a job's turn in the queue would take longer.


rule envelope_member:
    """A member's manifest, raw/<member>/dataset.yaml: the envelope's (or the validation's)
    dataset's with the member's draw of every varied unknown (a protocol's values as
    protocol_overrides), running only its design's stages."""
    input:
        base=lambda w: RAW / MEMBER_BASE[w.dataset] / "dataset.yaml",
        unknowns=UNKNOWNS,
        library=library_sources("envelope_member"),
    output:
        manifest=RAW / "{dataset}" / "dataset.yaml",
    log:
        "logs/{dataset}/envelope_member.log",
    benchmark:
        "benchmarks/out/{dataset}/envelope_member.tsv"
    wildcard_constraints:
        dataset="|".join(MEMBERS) or "^$",
    localrule: True
    threads: 1
    resources:
        **resources_for("small"),
    params:
        member=lambda w: MEMBERS[w.dataset],
    script:
        "../scripts/envelope_member.py"


rule envelope_plan:
    """The sampling plan: every member's value of every varied unknown, and the same draws in the
    unit hypercube as SALib drew them (what Morris's screening reads)."""
    input:
        base=RAW / ENVELOPE.design.dataset / "dataset.yaml",
        unknowns=UNKNOWNS,
        library=library_sources("envelope_plan"),
    output:
        plan=report(
            f"{ENVELOPE_FOLDER}/plan.csv",
            caption="../report/envelope_plan.rst",
            category="Envelope",
            subcategory="Plan",
        ),
        unit=f"{ENVELOPE_FOLDER}/unit.csv",
    log:
        f"logs/envelope/{ENVELOPE.design.name}/plan.log",
    benchmark:
        f"benchmarks/out/envelope/{ENVELOPE.design.name}/plan.tsv"
    localrule: True
    threads: 1
    resources:
        **resources_for("small"),
    params:
        design=ENVELOPE.design.record(),
    script:
        "../scripts/envelope_plan.py"


rule envelope:
    """Every emergent number of the nominal scorecard against its envelope over the members:
    percentiles, verdict (consistent, consistent (uninformative), inconsistent, no verdict) and
    the Morris groups that drive it; the ensemble's tables; the forest and tornado figures; the
    opening's counts."""
    input:
        unpack(envelope_inputs),
        registry=SCORECARD_REGISTRY,
        unknowns=UNKNOWNS,
        library=library_sources("envelope"),
    output:
        card=report(
            f"{ENVELOPE_FOLDER}/scorecard.csv",
            caption="../report/envelope.rst",
            category="Envelope",
            subcategory="Scorecard",
        ),
        sensitivity=report(
            f"{ENVELOPE_FOLDER}/sensitivity.csv",
            caption="../report/envelope_sensitivity.rst",
            category="Envelope",
            subcategory="Scorecard",
        ),
        # the ensemble's tables (members × rows, members × signatures; members × inputs is the
        # plan): a later method re-judges from them without running a member again
        values=f"{ENVELOPE_FOLDER}/values.csv",
        signatures=f"{ENVELOPE_FOLDER}/signatures.csv",
        forest=report(
            f"{ENVELOPE_FOLDER}/forest.png",
            caption="../report/envelope_forest.rst",
            category="Envelope",
            subcategory="Figures",
        ),
        tornado=report(
            f"{ENVELOPE_FOLDER}/tornado.png",
            caption="../report/envelope_tornado.rst",
            category="Envelope",
            subcategory="Figures",
        ),
        summary=report(
            f"{ENVELOPE_FOLDER}/envelope_summary.rst",
            caption="../report/envelope_summary.rst",
            category="Envelope",
            subcategory="Scorecard",
        ),
    log:
        f"logs/envelope/{ENVELOPE.design.name}/envelope.log",
    benchmark:
        f"benchmarks/out/envelope/{ENVELOPE.design.name}/envelope.tsv"
    localrule: True
    threads: 1
    resources:
        **resources_for("medium"),
    params:
        pdf=FIGURE_PDF,
        design=ENVELOPE.design.record(),
        raw_dir=config["raw_dir"],
        cards=[member_file(m, "scorecard.csv") for m in ENVELOPE.manifests],
    script:
        "../scripts/envelope.py"
