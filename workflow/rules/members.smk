# A member of the envelope or the validation in one job (selfsense.envelope.member): its rules'
# own jobs, from Snakemake's DAG of what is read of it, run by their scripts in one process, its
# captures in a scratch folder. With envelope.in_process or validation.in_process false,
# a member's rules run as the jobs of any dataset instead; the numbers are the same.


rule member_steps:
    """A group's members (the envelope's, or one validation batch's) as the steps their rules'
    jobs are: Snakemake's own DAG of each member's results, made from nothing."""
    input:
        library=workflow_sources(),
    output:
        steps=temp("results/{folder}/steps/{group}.json"),
    log:
        "logs/{folder}/steps/{group}.log",
    benchmark:
        "benchmarks/out/{folder}/steps/{group}.tsv"
    wildcard_constraints:
        folder=MEMBER_FOLDERS,
    localrule: True
    threads: 1
    resources:
        **resources_for("medium"),
    params:
        snakefile=workflow.main_snakefile,
        results=lambda w: {
            m: [f"results/{m}/{r}" for r in member_results(m)]
            for m in group_members(w.folder, w.group)
        },
        manifests=lambda w: [
            str(RAW / m / "dataset.yaml") for m in group_members(w.folder, w.group)
        ],
        run_config=config,
    script:
        "../scripts/member_steps.py"


rule member:
    """One member in one job: its rules' scripts run in order in one process, keeping only what
    is read of it (its scorecard; a validation member's common targets' tables too)."""
    input:
        steps=lambda w: member_steps_file(w.member),
        manifest=RAW / "{member}" / "dataset.yaml",
        library=workflow_sources(),
    output:
        folder=temp(directory("results/{folder}/members/{member}")),
    log:
        "logs/{folder}/members/{member}.log",
    benchmark:
        "benchmarks/out/{folder}/members/{member}.tsv"
    wildcard_constraints:
        folder=MEMBER_FOLDERS,
        member="|".join(map(re.escape, MEMBERS)) or "^$",
    threads: 1
    resources:
        **resources_for("stream_long"),
    params:
        keep=lambda w: member_results(w.member),
        failure=lambda w: member_failure(w.member),
    script:
        "../scripts/member.py"
