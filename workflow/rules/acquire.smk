# Stage "acquire": raw captures and their QC reports. Simulated datasets get them from the twin,
# which validates a capture as it writes it (read back whole, hashed and checked before the rename)
# and writes its report in the same job; measured captures are given, never written, and
# check_capture validates them.


if SIMULATED:

    rule simulate:
        """Run one experiment of the catalogue on the digital twin; validate and report the capture.
        A Ronkanen run compensated with the identified R and c (Eq 15) reads them from the
        powerloss stage's identification, made from the hold and the fixed-impedance ramps."""
        input:
            unpack(lambda w: identified_compensation(w.dataset, w.experiment)),
            manifest=RAW / "{dataset}" / "dataset.yaml",
            protocol=lambda w: protocol_file(w.dataset, w.experiment),
            library=library_sources("simulate"),
        output:
            capture=RAW / "{dataset}" / "{experiment}.nc",
            report="results/{dataset}/qc/{experiment}.json",
        log:
            "logs/{dataset}/simulate/{experiment}.log",
        benchmark:
            "benchmarks/out/{dataset}/simulate/{experiment}.tsv"
        wildcard_constraints:
            dataset="|".join(SIMULATED),
            # closed-loop runs need the identified model: rule simulate_closed_loop; the runs of
            # a protocol simulated together: its own rule, below
            experiment="".join(
                f"(?!{e}(?![A-Za-z0-9_]))" for e in SIMULATED_CLOSED_LOOP + SIMULATED_TOGETHER
            )
            + r"[A-Za-z0-9_]+",
        priority: longest_first
        threads: 1
        resources:
            **resources_for("simulate"),
        params:
            campaign=config["campaign"],
            capture_settings=config["capture"],
        script:
            "../scripts/simulate.py"

    for _name, (_protocol, _runs, _datasets) in TOGETHER.items():

        rule:
            """Run every experiment of one protocol on the digital twin in one job (config
            twin.together); validate and report each capture, as rule simulate does."""
            name:
                _name
            input:
                manifest=RAW / "{dataset}" / "dataset.yaml",
                protocol=str(PROTOCOLS / f"{_protocol}.yaml"),
                library=library_sources("simulate"),
            output:
                capture=[RAW / "{dataset}" / f"{e}.nc" for e in _runs],
                report=[f"results/{{dataset}}/qc/{e}.json" for e in _runs],
            log:
                f"logs/{{dataset}}/{_name}.log",
            benchmark:
                f"benchmarks/out/{{dataset}}/{_name}.tsv"
            wildcard_constraints:
                dataset="|".join(re.escape(d) for d in _datasets),
            priority: lambda w, runs=_runs: sum(samples(w.dataset, e) for e in runs) // 1000
            threads: 1
            resources:
                **resources_for("simulate"),
            params:
                campaign=config["campaign"],
                capture_settings=config["capture"],
            script:
                "../scripts/simulate.py"


if MEASURED:

    rule check_capture:
        """Check one measured capture against its manifest, validate it and count its NaN and
        clipped samples (streamed once). The manifest is an ancient() input: `selfsense import`
        appends each new recording to its experiments, and that must not check every earlier
        capture again; the parts of the manifest a capture is held to are a param, so a change
        to them (and only to them) re-checks every capture."""
        input:
            capture=RAW / "{dataset}" / "{experiment}.nc",
            manifest=ancient(RAW / "{dataset}" / "dataset.yaml"),
            library=library_sources("check_capture"),
        output:
            report="results/{dataset}/qc/{experiment}.json",
        log:
            "logs/{dataset}/check_capture/{experiment}.log",
        benchmark:
            "benchmarks/out/{dataset}/check_capture/{experiment}.tsv"
        wildcard_constraints:
            dataset="|".join(MEASURED),
        threads: 1
        resources:
            **resources_for("medium"),
        params:
            contract=lambda w: capture_contract(w.dataset),
        script:
            "../scripts/check_capture.py"


rule capture_summary:
    """One table of every capture of a dataset: duration, channels, NaN and clipped counts."""
    input:
        reports=lambda w: [f"results/{w.dataset}/qc/{e}.json" for e in CAPTURES[w.dataset]],
        library=library_sources("capture_summary"),
    output:
        table=report(
            "results/{dataset}/qc/captures.csv",
            caption="../report/captures.rst",
            category="{dataset}",
            subcategory="Captures",
        ),
    log:
        "logs/{dataset}/capture_summary.log",
    benchmark:
        "benchmarks/out/{dataset}/capture_summary.tsv"
    threads: 1
    resources:
        **resources_for("small"),
    script:
        "../scripts/capture_summary.py"


ACQUIRE_OUTPUTS = expand(rules.capture_summary.output, dataset=DATASETS)
