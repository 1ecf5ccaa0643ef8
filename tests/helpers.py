"""What the tests share besides their fixtures (those are in tests/conftest.py): the repository's
root and scratch copies of it, the one way the tests run Snakemake, and the small synthetic
captures, manifests, configs and lab recordings of the fault and bring-your-own-data tests.

Test modules import these from here, never from one another.
"""

import contextlib
import fcntl
import hashlib
import importlib.util
import io
import shutil
import subprocess
import sys
from pathlib import Path

import netCDF4
import numpy as np
import pandas as pd
import yaml

from selfsense.cli import main as cli
from selfsense.io.capture import CaptureWriter, channel_spec, open_capture
from selfsense.io.manifest import load_yaml

ROOT = Path(__file__).resolve().parents[1]
#: the small configuration the tests run, relative to the repository (and to a scratch copy)
SMOKE_CONFIG = "tests/config/smoke.yaml"


# -- the repository and Snakemake ----------------------------------------------------------------

IGNORE = shutil.ignore_patterns(
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
    "*~[0-9]*",  # an envelope member's folders under raw/ (its manifest is made by the workflow)
)


def copy_repo(dest: Path) -> Path:
    """A copy of the repository's workflow files (no results, no captures) to run Snakemake in."""
    shutil.copytree(ROOT, dest, ignore=IGNORE)
    return dest


@contextlib.contextmanager
def smoke_tree_held(repo: Path):
    """The shared smoke tree held by this test alone, across pytest-xdist workers (a file lock
    beside the tree): a test that edits the tree for a moment holds it, and so does a copy of
    it, so that no copy takes the edit."""
    with open(Path(repo).parent / "smoke_tree.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)  # released when the file closes
        yield


def copy_smoke_tree(smoke_run: Path, dest: Path) -> Path:
    """A copy of the smoke tree, Snakemake's records included, checked to have nothing to do."""
    with smoke_tree_held(smoke_run):
        shutil.copytree(smoke_run, dest, symlinks=True)
    dry = run_snakemake(dest, "-n", "--quiet", "rules")
    assert dry.returncode == 0 and "Nothing to be done" in dry.stdout + dry.stderr, (
        f"the copy of the smoke tree is not up to date:\n{dry.stdout[-2000:]}"
    )
    return dest


def snakemake_command(*args, config=SMOKE_CONFIG, cores=2):
    """The command line of Snakemake with ``args`` (targets and options) and ``config`` (a path
    relative to the repository it runs in; None: the repository's config.yaml alone). The targets
    go before --configfile, which takes several values."""
    command = [sys.executable, "-m", "snakemake", "--cores", str(cores), *args]
    return command + (["--configfile", str(config)] if config is not None else [])


def run_snakemake(repo, *args, config=SMOKE_CONFIG, cores=2, timeout=1800, env=None):
    """Snakemake in ``repo`` (the shared smoke tree or a scratch copy), to its end: the finished
    process, its output captured as text. Every test that runs Snakemake runs it here (or starts
    :func:`snakemake_command` itself, to kill it or run two at once)."""
    return subprocess.run(
        snakemake_command(*args, config=config, cores=cores),
        cwd=repo,
        env=env,
        capture_output=True,
        text=True,
        timeout=timeout,
    )


def error_line(run, *fragments):
    """The one line of Snakemake's output that carries all fragments (the error, whole)."""
    lines = [
        line for line in (run.stdout + run.stderr).splitlines() if all(f in line for f in fragments)
    ]
    assert lines, f"no line with {fragments}:\n{run.stderr[-4000:]}"
    return lines[0]


def write_config(repo, name, datasets, **changes):
    """A config in the scratch copy: the smoke config with only these datasets (its path relative
    to repo)."""
    config = yaml.safe_load((ROOT / SMOKE_CONFIG).read_text())
    config |= {"datasets": list(datasets)} | changes
    (repo / f"{name}.yaml").write_text(yaml.safe_dump(config, sort_keys=False))
    return f"{name}.yaml"


def measured_copy_remakes(table: str) -> bool:
    """Whether the measured copy of the smoke bench (tests/workflow/test_byod.py) makes ``table``
    again, from the same samples in its own DAG, and is held to its bytes there: every table of
    pi_p885 but the twin's (they read /truth, which a measured capture has not) and the scorecard
    and stage plan (they differ by design). The rebuild test (tests/workflow/test_report.py)
    remakes the rest."""
    return (
        table.startswith("results/pi_p885/")
        and not table.startswith("results/pi_p885/twin/")
        and table not in ("results/pi_p885/scorecard.csv", "results/pi_p885/stages.csv")
    )


def load_module(path):
    """The Python file at path, imported as a module of its own (a script of the repository)."""
    path = Path(path)
    spec = importlib.util.spec_from_file_location(path.stem, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def script(name):
    """A rule's script from workflow/scripts, imported as a module (its main() is the rule)."""
    return load_module(ROOT / "workflow" / "scripts" / f"{name}.py")


_CONFIG = load_yaml(ROOT / "config.yaml")
#: what rule characterise_page gives its script besides its files: config.yaml's settings, and
#: no protocol periods, declared scalings, cycle rules or model settings (the library's defaults)
PAGE_SETTINGS = {
    "settle_s": _CONFIG["characterise"]["settle_s"],
    "min_hold_s": _CONFIG["characterise"]["min_hold_s"],
    "pdf": _CONFIG["figures"]["pdf"],
    "periods": None,
    "scalings": None,
    "cycle_rules": None,
    "hysteresis": None,
}


# -- small captures and manifests (the fault matrix, docs/reliability.md) ------------------------

CH3 = ("ch3_sine_10hz", "ch3_sine_1hz", "ch3_sine_0p1hz")
FS = 48000.0
PI = load_yaml(ROOT / "raw" / "pi_p885" / "dataset.yaml")
RANGES = PI["daq"]["ranges"]


def synthetic(path, n=9600, channels=("U", "I", "Ur", "Ir", "x_laser"), thermometers=0.0):
    """A small capture in the contract: a 10 Hz drive and a ripple folded to 4 kHz; with
    ``thermometers`` [Hz], the three IR thermometers at that rate reading 23 °C + 10 K/s·t."""
    t = np.arange(n) / FS
    values = {
        "U": 50 - 50 * np.cos(2 * np.pi * 10 * t),
        "I": 0.05 * np.sin(2 * np.pi * 10 * t),
        "Ur": 0.1 * np.sin(2 * np.pi * 4000 * t),
        "Ir": 0.05 * np.cos(2 * np.pi * 4000 * t),
        "x_laser": 1.5e-5 * (1 - np.cos(2 * np.pi * 10 * t)),
    }
    attrs = {
        "fs": FS,
        "fr_nominal": 1e5,
        "ns": 12,
        "nf": 4,
        "warmup_s": 0.0,
        "dataset": "bench",
        "experiment": Path(path).stem,
        "source": "measured",
    }
    slow = ("T_top", "T_mid", "T_bot") if thermometers else ()
    n_slow = int(np.ceil(n / FS * thermometers))
    specs = [channel_spec(c, *RANGES[c]) for c in (*channels, *slow)]
    with CaptureWriter(path, attrs, specs, n, n_slow, thermometers or None) as w:
        w.write({c: values[c] for c in channels})
        if slow:
            w.write(
                dict.fromkeys(slow, 23.0 + 10.0 * np.arange(n_slow) / thermometers), "time_slow"
            )
    return Path(path)


def manifest(name, experiments, channels=None, **changes):
    """The manifest of a measured dataset on pi_p885's DAQ (only ``channels``, if given)."""
    channels = list(channels or PI["daq"]["channels"])
    daq = dict(PI["daq"], channels=channels, ranges={c: RANGES[c] for c in channels})
    doc = {
        "name": name,
        "description": f"{name}: a measured bench dataset made for the fault tests",
        "source": "measured",
        "model": "stack",
        "actuator": PI["actuator"],
        "daq": daq,
        "protocols": ["ch3"],
        "experiments": list(experiments),
    }
    return doc | changes


def bench_manifest(tmp_path, **changes):
    """raw/bench/dataset.yaml under tmp_path for the synthetic captures (check_capture compares
    a capture with its manifest); its path as text."""
    folder = tmp_path / "manifests" / "bench"
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "dataset.yaml").write_text(
        yaml.safe_dump(manifest("bench", []) | changes, sort_keys=False, allow_unicode=True)
    )
    return str(folder / "dataset.yaml")


def add_measured(repo, smoke, name, experiments, channels=None):
    """raw/<name>/ in a scratch copy: a measured dataset made of smoke captures (only
    `channels`)."""
    folder = repo / "raw" / name
    folder.mkdir(parents=True)
    for e in experiments:
        src, dst = smoke / "raw" / "pi_p885" / f"{e}.nc", folder / f"{e}.nc"
        if channels is None:
            shutil.copyfile(src, dst)
            with netCDF4.Dataset(dst, "a") as nc:
                nc.dataset, nc.source = name, "measured"
        else:  # a DAQ that records fewer channels
            with open_capture(src) as cap:
                data, n = cap.read(list(channels)), cap.n
                attrs = {
                    k: v
                    for k, v in cap.attrs.items()
                    if k not in ("Conventions", "clipped_samples")
                }
            with CaptureWriter(
                dst,
                attrs | {"dataset": name, "source": "measured"},
                [channel_spec(c, *RANGES[c]) for c in channels],
                n,
            ) as w:
                w.write(data)
    doc = manifest(name, experiments, channels)
    (folder / "dataset.yaml").write_text(yaml.safe_dump(doc, sort_keys=False, allow_unicode=True))
    return folder


def set_codes(path, channel, start, n, code):
    """Overwrite n raw int16 samples of a channel (FILL = a NaN burst, ±INT16_FULL = clipped)."""
    with netCDF4.Dataset(path, "a") as nc:
        var = nc[channel]
        var.set_auto_maskandscale(False)
        var[start : start + n] = np.full(n, code, dtype=np.int16)


def edit_time(path, fn):
    """Replace a capture's time axis t by fn(t)."""
    with netCDF4.Dataset(path, "a") as nc:
        t = nc["time"][:]
        nc["time"][:] = fn(np.asarray(t))


def truncate(path):
    """Cut a file to its first half."""
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])


def gap_in_the_middle(path):
    """Shift samples 4000–4099 of a capture's time axis by 0.5 s: it breaks at sample 4000."""
    edit_time(
        path,
        lambda t: np.where((np.arange(len(t)) >= 4000) & (np.arange(len(t)) < 4100), t + 0.5, t),
    )


def one_line(message, path, *fragments):
    """The message is one line that starts with the path and carries every fragment."""
    assert "\n" not in message
    assert message.startswith(str(path)), message
    for f in fragments:
        assert f in message, message


def leftovers(folder):
    """Half-written files: capture/series .part files and atomic_path's hidden temporaries."""
    folder = Path(folder)
    if not folder.exists():
        return []
    return sorted(
        str(p)
        for p in folder.rglob("*")
        if p.is_file() and (p.name.endswith(".part") or p.name.startswith("."))
    )


def fingerprint(folder):
    """{file: (mode, mtime_ns, sha256)} of every file in a folder."""
    return {
        p.name: (
            p.stat().st_mode & 0o777,
            p.stat().st_mtime_ns,
            hashlib.sha256(p.read_bytes()).hexdigest(),
        )
        for p in sorted(Path(folder).iterdir())
    }


def capture_arrays(path):
    """Every variable of a capture (groups included) as raw arrays, and its global attributes."""
    out = {}
    with netCDF4.Dataset(path) as nc:
        attrs = {k: nc.getncattr(k) for k in nc.ncattrs()}
        for group in (nc, *nc.groups.values()):
            group.set_auto_maskandscale(False)
            for name, var in group.variables.items():
                out[f"{group.path}/{name}"] = np.asarray(var[:])
    return attrs, out


def assert_same_capture(a, b):
    """The two captures hold the same global attributes and the same raw arrays."""
    attrs_a, data_a = capture_arrays(a)
    attrs_b, data_b = capture_arrays(b)
    assert attrs_a == attrs_b
    assert data_a.keys() == data_b.keys()
    for key in data_a:
        np.testing.assert_array_equal(data_a[key], data_b[key], err_msg=f"{a} {key}")


# -- a lab's recording (bring your own data, docs/bring-your-own-data.md) ------------------------

#: a 1 Hz, ±150 V sine sampled at 5 kHz; x = B sin(ωt − φ) + B [m]
LAB_FS, LAB_F, LAB_A, LAB_B = 5000.0, 1.0, 150.0, 15e-6
#: φ: the ellipse's width is 2B·sin φ, 12 % of its stroke 2B
LAB_PHI = np.arcsin(0.12)


def ellipse(periods=3):
    """t [s], U [V] and x [m] of the lab's U–x ellipse."""
    t = np.arange(int(periods * LAB_FS / LAB_F)) / LAB_FS
    return (
        t,
        LAB_A * np.sin(2 * np.pi * LAB_F * t),
        LAB_B * np.sin(2 * np.pi * LAB_F * t - LAB_PHI) + LAB_B,
    )


def write_csv(path, t0=2.0):
    """The ellipse as a lab's CSV (time from t0, x in µm)."""
    t, u, x = ellipse()
    pd.DataFrame({"t [s]": t + t0, "U [V]": u, "x [um]": x * 1e6}).to_csv(path, index=False)
    return path


def imported(folder, source, *channel_args, experiment="sine_1hz", dataset="lab_stack", extra=()):
    """`selfsense import` of source into folder/raw/<dataset>/ (the folder it made)."""
    raw = folder / "raw"
    args = [
        str(source),
        "--dataset",
        dataset,
        "--experiment",
        experiment,
        "--raw-dir",
        str(raw),
        *extra,
    ]
    for c in channel_args:
        args += ["--channel", c]
    assert cli(["import", *args]) == 0
    return raw / dataset


# -- selfsense import, in this process ------------------------------------------------------------


def import_args(source, raw, *channels, dataset="lab", experiment="run", extra=()):
    """`selfsense import` arguments for source into raw/<dataset>/ with these --channel specs."""
    args = ["import", str(source), "--dataset", dataset, "--experiment", experiment]
    args += ["--raw-dir", str(raw), *extra]
    for c in channels:
        args += ["--channel", c]
    return args


def run_import_command(args):
    """The command in this process: its exit status and what it printed to stderr."""
    err = io.StringIO()
    with contextlib.redirect_stderr(err):
        status = cli(args)
    return status, err.getvalue()


def tree(folder):
    """{relative path: bytes} of every file under folder, and its folders (a failed import
    changes neither)."""
    folder = Path(folder)
    if not folder.exists():
        return {}
    return {
        str(p.relative_to(folder)): (p.read_bytes() if p.is_file() else None)
        for p in sorted(folder.rglob("*"))
    }


def refused(args, *fragments, starts=None):
    """The import exits 1 with one line ('selfsense import: <file or argument>: …') carrying every
    fragment, and the raw folder is as it was (nothing made, nothing left behind)."""
    raw = Path(args[args.index("--raw-dir") + 1])
    before = tree(raw.parent)  # raw's parent: raw's name may be too long to ask about
    status, err = run_import_command(args)
    lines = [line for line in err.splitlines() if line.startswith("selfsense import: ")]
    assert status == 1 and len(lines) == 1, err
    message = lines[0][len("selfsense import: ") :]
    assert message.startswith(str(starts if starts is not None else args[1])), message
    for f in fragments:
        assert f in message, message
    assert tree(raw.parent) == before and leftovers(raw.parent) == []
    return message


def imports(args):
    """The import exits 0 and leaves no temporary: the capture's path and what it printed."""
    status, err = run_import_command(args)
    assert status == 0, err
    raw = Path(args[args.index("--raw-dir") + 1])
    dataset, experiment = args[args.index("--dataset") + 1], args[args.index("--experiment") + 1]
    assert leftovers(raw) == []
    return raw / dataset / f"{experiment}.nc", err
