"""Throughput, time and memory figures of the pipeline, printed for benchmarks/README.md.

    .venv/bin/python benchmarks/run.py [--seconds 20] [--configs CONFIG ...] [--fresh [--no-warm]
                                       [--keep-results DIR] [--against REFERENCE]]
                                       [--envelope [--members-only]]
                                       [--validate] [--members REFERENCE [--member-count N]
                                       [--member-design FILE]]
                                       [--skip-hot] [--skip-dag] [--skip-stream]

Prints, in three parts that can be skipped one by one:
- hot paths: the twin kernel (samples/s per core), a whole simulated capture (samples/s), capture
  write and read throughput with zlib level 1, with the twin's compression and uncompressed,
  ripple extraction and HPO throughput with their ratio to just reading the channels they consume;
- the DAG: `snakemake --cores 2` on the small and on the full configuration, each from scratch:
  in a scratch copy run by this interpreter (warm), or with --fresh in a new clone of HEAD with a
  new venv (the README's first command: no bytecode, no numba cache) and then again in that
  clone with its caches (warm). Each run: its wall time, CPU and the peak memory of its whole
  process tree, the machine's speed just before and after it (a probe on work that is not ours),
  the rules' own figures from their `benchmark:` files (summed and per rule: seconds,
  max_rss), the share of the time per cause (simulating, writing captures, analysis, per-job
  start-up, idle cores), and without --fresh a no-op `snakemake -n` on the up-to-date tree;
- with --envelope, the DAG part is the reproduction envelope, `snakemake envelope --cores 2`, in
  a new clone: two members alone, one after the other (a member's cost on 2 cores; the first
  compiles the twin's kernels), then the rest (not with --members-only), and each member's
  jobs' own seconds;
- with --validate, the DAG part is the validation, `snakemake validate --cores 2`, in a new clone
  with a new venv (the config's members, from nothing: the members' simulations and analyses,
  the batches' tables and the verdicts), then the verdicts again from the tables alone;
- with --members REFERENCE, the DAG part is the cost of an envelope member in new clones of HEAD
  and of REFERENCE in turn: member 01 alone, then --member-count (four) together on 2 cores, a
  member's share of the wall time and of the CPU;
- streaming: the peak memory of `simulate` and of the streaming rules `extract_ripple` and
  `thermal_extract` for a capture of --seconds and one 10× longer (each in a fresh process, so
  peaks do not mix).
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import platform
import re
import resource
import runpy
import shutil
import subprocess
import sys
import tempfile
import time
from collections import defaultdict
from pathlib import Path

import numpy as np
import psutil

from selfsense.io.capture import TWIN_COMPRESSION

ROOT = Path(__file__).resolve().parents[1]
FS = 48000.0
# what a scratch copy leaves out: outputs, captures, caches (as tests/helpers.py's copy_repo)
SCRATCH_IGNORE = shutil.ignore_patterns(
    ".venv",
    ".git",
    ".snakemake",
    "results",
    "figures",
    "logs",
    "*.nc",
    "out",
    "__pycache__",
    ".hypothesis",
    ".pytest_cache",
    "report.html",
)


def best_of(fn, repeats=3):
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def params():
    from selfsense.io.manifest import load_dataset
    from selfsense.twin.experiment import daq_plan
    from selfsense.twin.params import TwinParams

    manifest = load_dataset(ROOT / "raw", "pi_p885")
    return TwinParams.from_manifest(manifest["twin"]), daq_plan(manifest)


def bench_kernel(seconds):
    from selfsense.twin import kernel as K

    p, _ = params()
    n = int(seconds * FS)
    U = 50 - 50 * np.cos(2 * np.pi * 50 * np.arange(n) / FS)
    kc = K.kernel_constants(p, FS)
    K.run(U[:100], U[:100] * 0, U[:100] * 0 + 23, kc, K.initial_state(kc, 23.0))  # compile
    t = best_of(lambda: K.run(U, 0 * U, 0 * U + 23, kc, K.initial_state(kc, 23.0)))
    print(f"twin kernel (numba, 1 core):           {n / t / 1e6:8.2f} M samples/s")


def speed_probe(when):
    """This machine's speed just before and after a DAG run, on work that is not ours (so that it
    stays comparable when our code changes): a pure-Python loop and numpy's sort, one core, best of
    3. Its cores run the same code a fifth slower from one hour to the next (other tenants of its
    host), and a run's wall time moves with them: runs on different days compare through these."""
    n = 3_000_000
    loop = best_of(lambda: sum(i * i for i in range(n)))
    values = np.random.default_rng(0).standard_normal(n)
    sort = best_of(lambda: np.sort(values))
    print(
        f"  speed probe {when}: Python loop {n / loop / 1e6:.1f} M iterations/s, numpy sort "
        f"{n / sort / 1e6:.1f} M values/s (one core)"
    )


def simulate(path, seconds, compression=TWIN_COMPRESSION):
    """A capture of ``seconds`` of 50 Hz drive on the twin, with (compression, complevel)."""
    from selfsense.methods.drive import Drive, Segment
    from selfsense.twin.bench import simulate_capture

    p, daq = params()
    drive = Drive("voltage", (Segment(seconds, 50.0, 0.0, 100.0),))
    return simulate_capture(
        path, p, daq, drive, {}, 1, "bench", compression=compression[0], complevel=compression[1]
    ).path


def bench_capture(seconds, tmp):
    from selfsense.io.capture import open_capture

    n = int(seconds * FS)
    for compression in (("zlib", 1), TWIN_COMPRESSION, (None, 0)):
        label = f"{compression[0]} {compression[1]}" if compression[0] else "none"
        path = tmp / f"cap_{label.replace(' ', '')}.nc"
        t = best_of(lambda: simulate(path, seconds, compression), repeats=1)
        print(
            f"simulate whole capture ({label:12s}, 9 ch): {n / t / 1e6:8.2f} M time steps/s "
            f"({path.stat().st_size / n / 9:.2f} B/sample)"
        )

        def read():
            with open_capture(path) as cap:
                for _ in cap.iter_chunks(["U", "I", "Ur", "Ir", "x_laser", "F"]):
                    pass

        t = best_of(read)
        print(f"read+unpack 6 channels ({label:12s}):  {6 * n / t / 1e6:8.2f} M samples/s")
    return tmp / f"cap_{TWIN_COMPRESSION[0]}{TWIN_COMPRESSION[1]}.nc"


def bench_ripple_and_hpo(path):
    from selfsense.io.capture import open_capture
    from selfsense.methods.observer import HPOGains, HybridPositionObserver
    from selfsense.methods.ripple import RippleExtractor, SamplingPlan

    def read(names):
        with open_capture(path) as cap:
            for _ in cap.iter_chunks(names):
                pass

    with open_capture(path) as cap:
        n = cap.n
        data = cap.read(["Ur", "Ir", "I"])
    t_read = best_of(lambda: read(["Ur", "Ir"]))
    chunk = 1 << 18

    def ripple():
        ex = RippleExtractor(SamplingPlan(1e5, 12, 4, 4))
        for s in range(0, n, chunk):
            ex.process(data["Ur"][s : s + chunk], data["Ir"][s : s + chunk])

    t_rip = best_of(ripple)
    print(
        f"ripple extraction (np=4, 1 core):      {2 * n / t_rip / 1e6:8.2f} M samples/s "
        f"= {t_read / t_rip:.2f}× reading Ur+Ir ({2 * n / t_read / 1e6:.1f} M/s)"
    )

    obs = HybridPositionObserver(HPOGains(17.0), FS)
    xcp = np.zeros(n)
    obs.step(data["I"][:100], xcp[:100])
    t_hpo = best_of(lambda: obs.step(data["I"], xcp))
    t_read_i = best_of(lambda: read(["I"]))
    print(
        f"HPO (numba, 1 core):                   {n / t_hpo / 1e6:8.2f} M samples/s "
        f"= {t_read_i / t_hpo:.2f}× reading I"
    )


def peak_rss_mb(code):
    """Peak RSS [MB] of a fresh interpreter running code (run.py importable as `run`).

    Read as VmHWM from /proc, which starts afresh at exec; getrusage's ru_maxrss does not (Linux
    carries it across fork and exec), so it would report this process's own size when that is
    larger.
    """
    code = (
        f"import sys; sys.path.insert(0, {str(ROOT / 'benchmarks')!r}); import run; {code}; "
        "print(next(l.split()[1] for l in open('/proc/self/status') if l.startswith('VmHWM:')))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    return int(out.stdout.split()[-1]) / 1024


def run_script(name, *args):
    """A rule's script run alone (workflow/scripts/<name>.py), as the rule runs it."""
    sys.argv = [name, *args]
    runpy.run_path(str(ROOT / "workflow" / "scripts" / f"{name}.py"), run_name="__main__")


def bench_streaming(seconds, tmp):
    """Peak memory of simulate and of the streaming rules for a capture and one 10x longer."""
    model = tmp / "model.json"
    model.write_text(json.dumps({"k_over_alpha": 2.68e6}))  # Table 4.3; only scales the loss power
    peaks = defaultdict(list)
    for length in (seconds, 10 * seconds):
        cap = tmp / f"stream_{length:g}.nc"
        peaks["simulate"].append(peak_rss_mb(f"run.simulate({str(cap)!r}, {length})"))
        peaks["extract_ripple"].append(
            peak_rss_mb(
                f"run.run_script('extract_ripple', {str(cap)!r}, {str(tmp / 'series.nc')!r})"
            )
        )
        peaks["thermal_extract"].append(
            peak_rss_mb(
                f"run.run_script('thermal_extract', {str(cap)!r}, "
                f"{str(model)!r}, {str(tmp / 'p.nc')!r}, {str(tmp / 'g.nc')!r})"
            )
        )
        cap.unlink()
    for name, (short, long) in peaks.items():
        print(
            f"{name + ' peak RSS:':25s} {short:5.0f} MB for {seconds:g} s, {long:5.0f} MB for "
            f"{10 * seconds:g} s (ratio {long / short:.2f})"
        )


def run_sampled(cmd, cwd, every=0.5):
    """Run cmd between two speed probes; return (wall seconds, peak summed RSS [MB] of its process
    tree, sampled, and the CPU seconds of the whole tree: the kernel's own count of every process
    reaped, exact where the benchmark files' cpu_time is sampled)."""
    speed_probe("before")
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    with open(
        Path(cwd) / "benchmark-run.log", "w+"
    ) as log:  # a file: a full pipe would stall the run
        t0 = time.perf_counter()
        proc = subprocess.Popen(cmd, cwd=cwd, stdout=log, stderr=subprocess.STDOUT)
        root, peak = psutil.Process(proc.pid), 0
        while proc.poll() is None:
            rss = 0
            try:
                for p in [root, *root.children(recursive=True)]:
                    rss += p.memory_info().rss
            except psutil.NoSuchProcess:  # a job ended while we walked the tree
                pass
            peak = max(peak, rss)
            time.sleep(every)
        wall = time.perf_counter() - t0
        log.seek(0)
        if proc.returncode:
            sys.exit(f"{' '.join(cmd)} failed in {cwd}:\n{log.read()[-3000:]}")
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    speed_probe("after")
    return wall, peak / 2**20, after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime


def rule_of(tsv, out):
    """The rule a benchmark file belongs to: benchmarks/out/<dataset>/<rule>/<experiment>.tsv,
    benchmarks/out/<dataset>/<rule>.tsv or benchmarks/out/<rule>.tsv (workflow/rules/*.smk)."""
    parts = tsv.relative_to(out).parts
    return parts[1] if len(parts) == 3 else tsv.stem


def print_rss_by_capture_length(
    repo,
    out,
    rules=("simulate", "check_capture", "extract_ripple", "observe", "thermal_extract", "coupled"),
):
    """max_rss of the per-capture rules against the length (in samples) of the capture each job
    streamed: the shortest and the longest capture of each rule, from the benchmark files.

    Jobs under a second are left out: Snakemake samples a job's memory every 0.5 s (every 30 s
    after the first 15 s), so their max_rss is whatever the first sample caught.
    """
    import netCDF4

    print("  peak memory against capture length (benchmark files; per-capture rules, jobs ≥ 1 s):")
    for rule in rules:
        jobs = []
        for tsv in out.glob(f"*/{rule}/*.tsv"):
            with tsv.open() as f:
                row = next(csv.DictReader(f, delimiter="\t"))
            if float(row["s"]) >= 1.0:
                with netCDF4.Dataset(
                    repo / "raw" / tsv.parent.parent.name / f"{tsv.stem}.nc"
                ) as nc:
                    jobs.append((nc.dimensions["time"].size / 1e6, float(row["max_rss"])))
        if len(jobs) > 1:
            (short, rss_short), (long, rss_long) = min(jobs), max(jobs)
            print(
                f"    {rule:22s} {rss_short:5.0f} MB at {short:6.2f} M samples, "
                f"{rss_long:5.0f} MB at {long:6.1f} M "
                f"(largest of {len(jobs)} jobs {max(j[1] for j in jobs):5.0f} MB)"
            )


def job_rows(out):
    """{rule: [(s, max_rss) per job]} from the DAG's benchmark files."""
    rules = defaultdict(list)
    for tsv in sorted(out.rglob("*.tsv")):
        with tsv.open() as f:
            row = next(csv.DictReader(f, delimiter="\t"))
        rules[rule_of(tsv, out)].append((float(row["s"]), float(row["max_rss"])))
    return rules


def startup_seconds(repo, python, rule):
    """A job's start-up: a fresh interpreter importing Snakemake's script module (the preamble of
    every script job) and the rule's script with its imports (best of 2, wall)."""
    script = repo / "workflow" / "scripts" / f"{rule}.py"
    code = (
        "import sys, runpy, snakemake.script; sys.argv = ['x', '--help']; "
        f"runpy.run_path({str(script)!r}, run_name='__main__')"
    )
    times = []
    for _ in range(2):
        t0 = time.perf_counter()
        subprocess.run([str(python), "-c", code], cwd=repo, capture_output=True, check=False)
        times.append(time.perf_counter() - t0)
    return min(times)


CAPTURE_WRITE = re.compile(r"packing and writing ([\d.]+) s, reading back ([\d.]+) s")
SIMULATING = ("simulate", "simulate_closed_loop")


def print_shares(repo, python, rules, wall):
    """Where the jobs' time went: per-job start-up (measured per rule, times its jobs), writing
    captures (packing, compressing, writing, reading back: the writers' log lines), simulating the
    bench (the twin's jobs less those two) and analysis (every other job less its start-up)."""
    startup = {rule: startup_seconds(repo, python, rule) * len(js) for rule, js in rules.items()}
    write = sum(
        float(a) + float(b)
        for log in (repo / "logs").glob("*/simulate*/*.log")
        for a, b in CAPTURE_WRITE.findall(log.read_text())
    )
    busy = {rule: sum(j[0] for j in js) for rule, js in rules.items()}
    total = sum(busy.values())
    simulate = sum(busy.get(r, 0) - startup.get(r, 0) for r in SIMULATING) - write
    analysis = sum(b - startup[r] for r, b in busy.items() if r not in SIMULATING)
    print(f"  share of the jobs' {total:.0f} s (2 cores × wall {wall:.0f} s = {2 * wall:.0f} s):")
    for cause, seconds in (
        ("simulate (twin kernel, instruments, real-time loop)", simulate),
        ("capture write (pack, compress, write, read back)", write),
        ("analysis (every other job's own work)", analysis),
        ("per-job start-up (interpreter, Snakemake preamble, imports)", sum(startup.values())),
        ("cores idle (scheduling, the DAG's narrow parts)", 2 * wall - total),
    ):
        print(f"    {cause:62s} {seconds:7.0f} s  {100 * seconds / (2 * wall):5.1f} %")


def report_dag(label, repo, python, config, wall, peak, cpu):
    out = repo / "benchmarks" / "out"
    rules = job_rows(out)
    jobs = [j for js in rules.values() for j in js]
    job_s = sum(j[0] for j in jobs)
    print(
        f"DAG ({config}, --cores 2, {label}): {len(jobs)} jobs, wall {wall:.0f} s, "
        f"CPU {cpu:.0f} s (user + sys of Snakemake and every job), "
        f"peak RSS of the process tree {peak:.0f} MB (sampled every 0.5 s)"
    )
    # Snakemake samples a job's cpu_time every 30 s after its first 15 s: a long job's is short by
    # up to 30 s
    print(
        f"  jobs' own time (benchmark files): {job_s:.0f} s summed ({job_s / wall:.2f}× wall); "
        f"largest job max_rss {max(j[1] for j in jobs):.0f} MB"
    )
    print(f"  {'rule':24s} {'jobs':>4s} {'s (sum)':>8s} {'s (max)':>8s} {'max_rss MB':>10s}")
    for rule, js in sorted(rules.items(), key=lambda kv: -sum(j[0] for j in kv[1])):
        print(
            f"  {rule:24s} {len(js):4d} {sum(j[0] for j in js):8.1f} {max(j[0] for j in js):8.1f} "
            f"{max(j[1] for j in js):10.0f}"
        )
    print_shares(repo, python, rules, wall)
    print_rss_by_capture_length(repo, out)


def noop_dry_run(snakemake, repo):
    times = []
    for _ in range(3):
        t0 = time.perf_counter()
        dry = subprocess.run([*snakemake, "-n"], cwd=repo, capture_output=True, text=True)
        times.append(time.perf_counter() - t0)
        if "Nothing to be done" not in dry.stdout + dry.stderr:
            sys.exit(f"the tree is not up to date after the run:\n{dry.stdout[-3000:]}")
    print(
        f"no-op `snakemake -n` on the up-to-date tree: {min(times):.1f} s (best of 3; "
        f"{', '.join(f'{t:.1f}' for t in times)})"
    )


def bench_dag(config):
    """The whole DAG on one configuration from nothing in a scratch copy, run by this interpreter
    (warm: its installed packages, bytecode and numba cache), then a no-op dry run."""
    snakemake = [sys.executable, "-m", "snakemake", "--cores", "2", "--configfile", config]
    with tempfile.TemporaryDirectory() as tmp:
        repo = Path(tmp) / "repo"
        shutil.copytree(ROOT, repo, ignore=SCRATCH_IGNORE)
        wall, peak, cpu = run_sampled(snakemake, repo)
        report_dag("warm", repo, sys.executable, config, wall, peak, cpu)
        noop_dry_run(snakemake, repo)


def new_clone(folder, commit=None):
    """A new clone of the committed HEAD (or ``commit``) in folder with a new venv and the pinned
    packages (the README's install): (repo, its python, install seconds)."""
    repo = Path(folder) / "repo"
    subprocess.run(["git", "clone", "--quiet", str(ROOT), str(repo)], check=True)
    if commit:
        subprocess.run(["git", "checkout", "--quiet", commit], cwd=repo, check=True)
    python = repo / ".venv" / "bin" / "python"
    t0 = time.perf_counter()
    subprocess.run(
        [shutil.which("python3.11") or sys.executable, "-m", "venv", ".venv"], cwd=repo, check=True
    )
    subprocess.run(
        [str(python), "-m", "pip", "install", "-q", "-c", "constraints.txt", "-e", "."],
        cwd=repo,
        check=True,
        capture_output=True,
    )
    return repo, python, time.perf_counter() - t0


def bench_fresh_clone(config, keep_results=None, warm=True, commit=None):
    """The README's first command as a new user runs it: a new clone of the committed HEAD (or
    ``commit``), a new venv with the pinned packages, `snakemake --cores 2` (no bytecode, no numba
    cache); then the same clone again from nothing but with its venv and caches (warm).
    ``keep_results``: a folder that gets the fresh run's results/ (for compare_results.py)."""
    if commit:
        print(f"the commit {commit}:")
    with tempfile.TemporaryDirectory() as tmp:
        repo, python, install = new_clone(tmp, commit)
        snakemake = [str(python), "-m", "snakemake", "--cores", "2", "--configfile", config]
        fresh, peak, cpu = run_sampled(snakemake, repo)
        report_dag("fresh clone", repo, python, config, fresh, peak, cpu)
        if keep_results:
            shutil.copytree(repo / "results", Path(keep_results) / "results", dirs_exist_ok=True)
        if not warm:
            print(
                f"fresh clone ({config}): install {install:.0f} s, "
                f"`snakemake --cores 2` {fresh:.0f} s "
                f"(README's first command {install + fresh:.0f} s)"
            )
            return
        # outputs, captures and logs go; the venv, bytecode and numba's cache (src/**/__pycache__)
        # stay
        subprocess.run(
            ["git", "clean", "-fdxq", "-e", ".venv", "-e", "__pycache__"], cwd=repo, check=True
        )
        warm, peak, cpu = run_sampled(snakemake, repo)
        report_dag("the same clone again, warm", repo, python, config, warm, peak, cpu)
        print(
            f"fresh clone ({config}): install {install:.0f} s, `snakemake --cores 2` {fresh:.0f} s "
            f"(README's first command {install + fresh:.0f} s); warm {warm:.0f} s"
        )


def bench_envelope(config, keep_results=None, members_only=False):
    """`snakemake envelope --cores 2` in a new clone of HEAD with a new venv: first two members
    alone, one after the other (their own jobs only: what a member costs on 2 cores; the first
    also compiles the twin's kernels), then the envelope (the nominal dataset's scorecard and the
    other members; not with ``members_only``); per member, its jobs' own seconds."""
    from selfsense.io.manifest import load_config

    dataset = load_config(ROOT / config)["envelope"]["dataset"]
    with tempfile.TemporaryDirectory() as tmp:
        repo, python, install = new_clone(tmp)
        snakemake = [str(python), "-m", "snakemake", "--cores", "2"]
        alone = []
        for n in ("01", "02"):
            # the targets before --configfile, which takes several values
            target = f"results/{dataset}~{n}/scorecard.csv"
            wall, peak, cpu = run_sampled([*snakemake, target, "--configfile", config], repo)
            alone.append(wall)
            print(
                f"envelope ({config}): member {n} alone: {wall:.1f} s, CPU {cpu:.0f} s, "
                f"peak RSS {peak:.0f} MB" + (" (compiles the kernels)" if n == "01" else "")
            )
        one = sum(alone)
        print(f"  install {install:.0f} s; the two members {one:.0f} s")
        if members_only:
            return
        rest, peak, cpu = run_sampled([*snakemake, "envelope", "--configfile", config], repo)
        out = repo / "benchmarks" / "out"
        members = sorted(p for p in out.iterdir() if p.name.startswith(f"{dataset}~"))
        job_s = [sum(sum(j[0] for j in js) for js in job_rows(m).values()) for m in members]
        print(
            f"  then `snakemake envelope`: {rest:.0f} s (the nominal {dataset} and "
            f"{len(members) - 2} more members), CPU {cpu:.0f} s, peak RSS {peak:.0f} MB; "
            f"whole envelope {one + rest:.0f} s, with the install {install + one + rest:.0f} s"
        )
        print(
            f"  a member's jobs' own time: mean {np.mean(job_s):.0f} s, largest {max(job_s):.0f} s "
            f"(÷ 2 cores: {np.mean(job_s) / 2:.0f} s)"
        )
        if keep_results:
            shutil.copytree(repo / "results", Path(keep_results) / "results", dirs_exist_ok=True)


def bench_members(config, reference, count=4, design=None):
    """The cost of an envelope member of ``config``'s campaign, in a new clone of HEAD and one of
    ``reference`` in the same run, in turn: member 01 alone (in a new clone: it compiles the
    twin's kernels), then members 02…``count`` + 1 together on 2 cores; per member, the wall
    time and the CPU of the whole run divided by the members. HEAD runs each member as one job
    (rule member, the envelope's steps made first, their time included); ``reference`` runs
    whatever it runs for ``results/<member>/scorecard.csv``. ``design``: a configfile given after
    ``config`` whose ``envelope`` section is the design (Chapter 7's, docs/envelope.md)."""
    from selfsense.io.manifest import load_config, load_yaml

    section = load_config(ROOT / config)["envelope"]
    configfiles = [config]
    if design:
        section |= load_yaml(design)["envelope"]
        configfiles.append(str(Path(design).resolve()))
    name = section["name"] or section["dataset"]
    for label, commit in ((f"reference {reference}", reference), ("HEAD", None)):
        with tempfile.TemporaryDirectory() as tmp:
            repo, python, install = new_clone(tmp, commit)
            in_one_job = (repo / "workflow" / "rules" / "members.smk").exists()
            members = [f"{name}~{n:02d}" for n in range(1, count + 2)]
            folder = f"results/envelope/{name}/members"
            targets = [
                f"{folder}/{m}" if in_one_job else f"results/{m}/scorecard.csv" for m in members
            ]
            snakemake = [str(python), "-m", "snakemake", "--cores", "2"]
            parts = (("member 01 alone", targets[:1]), (f"{count} members", targets[1:]))
            for part, chosen in parts:
                wall, peak, cpu = run_sampled(
                    [*snakemake, *chosen, "--configfile", *configfiles], repo
                )
                n = len(chosen)
                print(
                    f"{label} ({'one job a member' if in_one_job else 'the rules'}), {config}, "
                    f"{part}: {wall:.1f} s wall, {cpu:.0f} s CPU in all; a member "
                    f"{wall / n:.1f} s wall, {cpu / n:.1f} s CPU; peak RSS {peak:.0f} MB"
                )


def bench_validate(config):
    """`snakemake validate --cores 2` in a new clone of HEAD with a new venv, from nothing (the
    install apart), then the verdicts alone again from the batches' tables (rule
    validation_verdicts forced: no member runs)."""
    from selfsense.io.manifest import load_config

    section = load_config(ROOT / config)["validation"]
    with tempfile.TemporaryDirectory() as tmp:
        repo, python, install = new_clone(tmp)
        snakemake = [str(python), "-m", "snakemake", "--cores", "2"]
        wall, peak, cpu = run_sampled([*snakemake, "validate", "--configfile", config], repo)
        print(
            f"validate ({config}, {section['members'] or 'the declared'} members a wave in "
            f"batches of {section['batch']}): install {install:.0f} s, `snakemake validate` "
            f"{wall:.0f} s (CPU {cpu:.0f} s, peak RSS {peak:.0f} MB): {install + wall:.0f} s "
            "from a new clone"
        )
        again, _, _ = run_sampled(
            [*snakemake, "validate", "--forcerun", "validation_verdicts", "--configfile", config],
            repo,
        )
        print(f"  the verdicts again from the tables alone: {again:.0f} s")


def main():
    cli = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    cli.add_argument(
        "--seconds", type=float, default=20.0, help="capture length for throughput and memory"
    )
    cli.add_argument(
        "--configs",
        nargs="+",
        default=["tests/config/smoke.yaml", "config.yaml"],
        help="configfiles of the DAG part, each run from scratch (default: small, then full)",
    )
    cli.add_argument("--skip-hot", action="store_true", help="skip the hot-path throughputs")
    cli.add_argument("--skip-dag", action="store_true", help="skip the whole-DAG run")
    cli.add_argument(
        "--fresh",
        action="store_true",
        help="run the DAG part from a new clone of HEAD with a new venv, then warm in that clone",
    )
    cli.add_argument("--skip-stream", action="store_true", help="skip the streaming peak memories")
    cli.add_argument(
        "--no-warm", action="store_true", help="with --fresh: skip the warm run in the clone"
    )
    cli.add_argument(
        "--keep-results", metavar="DIR", help="with --fresh: copy the fresh run's results/ to DIR"
    )
    cli.add_argument(
        "--envelope",
        action="store_true",
        help="the DAG part is `snakemake envelope`, in a new clone of HEAD (one member alone, "
        "then the rest)",
    )
    cli.add_argument(
        "--members-only",
        action="store_true",
        help="with --envelope: only the two members alone, not the whole envelope",
    )
    cli.add_argument(
        "--validate",
        action="store_true",
        help="the DAG part is `snakemake validate`, in a new clone of HEAD (from nothing, then "
        "the verdicts again from the tables alone)",
    )
    cli.add_argument(
        "--against",
        metavar="REFERENCE",
        help="with --fresh: the commit REFERENCE first, then HEAD, in turn (--keep-results DIR: "
        "DIR/reference and DIR/head)",
    )
    cli.add_argument(
        "--members",
        metavar="REFERENCE",
        help="the DAG part is the cost of an envelope member, in new clones of HEAD and of the "
        "commit REFERENCE in turn (one member alone, then --member-count together)",
    )
    cli.add_argument(
        "--member-count",
        type=int,
        default=4,
        metavar="N",
        help="with --members: how many members run together after the first (default 4; the "
        "run's parse and the members' steps are shared by them)",
    )
    cli.add_argument(
        "--member-design",
        metavar="FILE",
        help="with --members: a configfile after CONFIG whose envelope section is the members' "
        "design (Chapter 7's: docs/envelope.md)",
    )
    args = cli.parse_args()
    mem = psutil.virtual_memory().total / 2**30
    print(
        f"machine: {platform.machine()}, {os.cpu_count()} cores, {mem:.0f} GiB, python "
        f"{platform.python_version()}; load average at start {os.getloadavg()[0]:.1f}"
    )
    if not args.skip_hot:
        bench_kernel(args.seconds)
        with tempfile.TemporaryDirectory() as tmp:
            path = bench_capture(args.seconds, Path(tmp))
            bench_ripple_and_hpo(path)
    if not args.skip_dag:
        for config in args.configs:
            if args.members:
                bench_members(config, args.members, args.member_count, args.member_design)
            elif args.validate:
                bench_validate(config)
            elif args.envelope:
                bench_envelope(config, args.keep_results, args.members_only)
            elif args.fresh and args.against:
                for commit, folder in ((args.against, "reference"), (None, "head")):
                    keep = args.keep_results and str(Path(args.keep_results) / folder)
                    bench_fresh_clone(config, keep, not args.no_warm, commit)
            elif args.fresh:
                bench_fresh_clone(config, args.keep_results, not args.no_warm)
            else:
                bench_dag(config)
    if not args.skip_stream:
        with tempfile.TemporaryDirectory() as tmp:
            bench_streaming(args.seconds, Path(tmp))
    print(f"load average at end {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
