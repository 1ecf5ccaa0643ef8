# The validation (docs/validation.md): workflow/validation.yaml's waves run as members (VALIDATION
# in common.smk; their manifests by rule envelope_member), each batch's tables kept, and the
# verdicts made from those tables alone. Not part of rule all: `snakemake validate`. A member is
# one job (members.smk) or, with validation.in_process false, its rules' jobs. These rules are
# local: they read and write kilobytes, and on a cluster the members are the jobs.


rule validation_batch:
    """One batch's tables, from its members' scorecards and the tables the common targets read:
    members × inputs (the unit cube, the noise seed), the plan, members × rows, members ×
    targets. A batch whose tables exist is done: this rule never makes it again."""
    input:
        unpack(validation_batch_inputs),
        declaration=VALIDATION_DECLARATION,
        unknowns=UNKNOWNS,
        library=library_sources("validation_batch"),
    output:
        unit=f"{VALIDATION_FOLDER}/{{batch}}/inputs.csv",
        plan=f"{VALIDATION_FOLDER}/{{batch}}/plan.csv",
        rows=f"{VALIDATION_FOLDER}/{{batch}}/rows.csv",
        targets=f"{VALIDATION_FOLDER}/{{batch}}/targets.csv",
    log:
        f"logs/validation/{VALIDATION_PLAN.name}/{{batch}}.log",
    benchmark:
        f"benchmarks/out/validation/{VALIDATION_PLAN.name}/{{batch}}.tsv"
    wildcard_constraints:
        batch="|".join(VALIDATION.selected) or "^$",
    localrule: True
    threads: 1
    resources:
        **resources_for("small"),
    params:
        read=member_read,
        failures=member_failures,
        runs=lambda w: VALIDATION.inputs[w.batch].to_dict("list"),
        drawn=lambda w: VALIDATION.plans[w.batch].to_dict("list"),
        row_keys=list(VALIDATION.rows),
        locate=[list(t) for t in VALIDATION.targets],
    script:
        "../scripts/validation_batch.py"


rule validation_wave:
    """A later wave's design, from the earlier waves' members × inputs and × targets alone: a
    maximin subset of the prior candidates the common targets' emulators leave (no judged row
    steers where the simulator runs), or none, with the reason the waves stop."""
    input:
        unpack(validation_wave_inputs),
        declaration=VALIDATION_DECLARATION,
        sources=VALIDATION_SOURCES,
        registry=SCORECARD_REGISTRY,
        unknowns=UNKNOWNS,
        library=library_sources("validation_wave"),
    output:
        design=f"{VALIDATION_FOLDER}/wave{{wave}}/design.csv",
    log:
        f"logs/validation/{VALIDATION_PLAN.name}/wave{{wave}}_design.log",
    benchmark:
        f"benchmarks/out/validation/{VALIDATION_PLAN.name}/wave{{wave}}_design.tsv"
    wildcard_constraints:
        wave=str(VALIDATION.design_wave or "^$"),
    localrule: True
    threads: 1
    resources:
        **resources_for("large"),
    params:
        ids=list(VALIDATION.ids),
        first=VALIDATION.first,
    script:
        "../scripts/validation_wave.py"


rule validation_verdicts:
    """The validation's verdicts from the ensemble's tables alone: per emergent row its fold,
    conditioning folds, NROY fraction, posterior-predictive 2.5/50/97.5, the published value's
    implausibility and PIT, and verdict; the emulators' leave-one-out diagnostics; the waves'
    cut; the fold-compatibility map; the pseudo-theses' coverage and PIT histogram."""
    input:
        unpack(validate_inputs),
        declaration=VALIDATION_DECLARATION,
        sources=VALIDATION_SOURCES,
        registry=SCORECARD_REGISTRY,
        unknowns=UNKNOWNS,
        library=library_sources("validation_verdicts"),
    output:
        verdicts=report(
            f"{VALIDATION_FOLDER}/verdicts.csv",
            caption="../report/validation_verdicts.rst",
            category="Validation",
            subcategory="Verdicts",
        ),
        emulators=report(
            f"{VALIDATION_FOLDER}/emulators.csv",
            caption="../report/validation_emulators.rst",
            category="Validation",
            subcategory="Emulators",
        ),
        waves=f"{VALIDATION_FOLDER}/waves.csv",
        compatibility=report(
            f"{VALIDATION_FOLDER}/compatibility.csv",
            caption="../report/validation_compatibility.rst",
            category="Validation",
            subcategory="Folds",
        ),
        compatibility_map=report(
            f"{VALIDATION_FOLDER}/compatibility.png",
            caption="../report/validation_compatibility_map.rst",
            category="Validation",
            subcategory="Folds",
        ),
        coverage=report(
            f"{VALIDATION_FOLDER}/coverage.csv",
            caption="../report/validation_coverage.rst",
            category="Validation",
            subcategory="Pseudo-theses",
        ),
        pit=f"{VALIDATION_FOLDER}/pit.csv",
        pit_histogram=report(
            f"{VALIDATION_FOLDER}/pit_histogram.png",
            caption="../report/validation_pit_histogram.rst",
            category="Validation",
            subcategory="Pseudo-theses",
        ),
        sobol=f"{VALIDATION_FOLDER}/sobol.csv",
        summary=report(
            f"{VALIDATION_FOLDER}/validation_summary.rst",
            caption="../report/validation_summary.rst",
            category="Validation",
            subcategory="Verdicts",
        ),
    log:
        f"logs/validation/{VALIDATION_PLAN.name}/verdicts.log",
    benchmark:
        f"benchmarks/out/validation/{VALIDATION_PLAN.name}/verdicts.tsv"
    localrule: True
    threads: 1
    resources:
        **resources_for("large"),
    params:
        model=VALIDATION.model(),
        pdf=FIGURE_PDF,
        drivers=config["validation"]["drivers"],
    script:
        "../scripts/validation_verdicts.py"


rule validation_variants:
    """The twin's variants chosen by the data they are not judged on: today's twin, each
    variant alone and all of them, every fold predicted from the others on one set of
    emulators of the joined tables; each fold's state per model, the folds a variant reconciles
    and breaks, the compatibility maps, the declared rows side by side."""
    input:
        unpack(validate_inputs),
        declaration=VALIDATION_DECLARATION,
        sources=VALIDATION_SOURCES,
        registry=SCORECARD_REGISTRY,
        unknowns=UNKNOWNS,
        library=library_sources("validation_variants"),
    output:
        verdicts=f"{VALIDATION_FOLDER}/variants/verdicts.csv",
        compatibility=f"{VALIDATION_FOLDER}/variants/compatibility.csv",
        folds=report(
            f"{VALIDATION_FOLDER}/variants/folds.csv",
            caption="../report/validation_variants.rst",
            category="Validation",
            subcategory="Variants",
        ),
        side_by_side=report(
            f"{VALIDATION_FOLDER}/variants/rows.csv",
            caption="../report/validation_variant_rows.rst",
            category="Validation",
            subcategory="Variants",
        ),
        summary=f"{VALIDATION_FOLDER}/variants/variants_summary.rst",
    log:
        f"logs/validation/{VALIDATION_PLAN.name}/variants.log",
    benchmark:
        f"benchmarks/out/validation/{VALIDATION_PLAN.name}/variants.tsv"
    localrule: True
    threads: 1
    resources:
        **resources_for("large"),
    params:
        model=VALIDATION.model(),
        models=VALIDATION.models(),
    script:
        "../scripts/validation_variants.py"


rule validation_review:
    """The verdicts beside the nominal scorecard and the prior envelopes as committed
    (docs/snapshot/): one table, and the forest of the envelope's and the posterior's
    intervals."""
    input:
        unpack(validation_judges),
        verdicts=rules.validation_verdicts.output.verdicts,
        library=library_sources("validation_review"),
    output:
        review=report(
            f"{VALIDATION_FOLDER}/review.csv",
            caption="../report/validation_review.rst",
            category="Validation",
            subcategory="Verdicts",
        ),
        forest=report(
            f"{VALIDATION_FOLDER}/forest.png",
            caption="../report/validation_forest.rst",
            category="Validation",
            subcategory="Verdicts",
        ),
    log:
        f"logs/validation/{VALIDATION_PLAN.name}/review.log",
    benchmark:
        f"benchmarks/out/validation/{VALIDATION_PLAN.name}/review.tsv"
    localrule: True
    threads: 1
    resources:
        **resources_for("small"),
    params:
        title=f"{VALIDATION_PLAN.dataset}: prior envelope and posterior predictive",
        pdf=FIGURE_PDF,
    script:
        "../scripts/validation_review.py"


rule validate:
    """`snakemake validate`: the next batches, the verdicts from every batch done, the review."""
    input:
        rules.validation_verdicts.output,
        rules.validation_review.output,
        rules.validation_variants.output if VALIDATION_PLAN.variants else [],
    localrule: True
