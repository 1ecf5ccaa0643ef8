"""Peak memory and wall time of `selfsense import` on a long and on a wide CSV, and on a long NI
TDMS and MATLAB v7.3 file.

    .venv/bin/python benchmarks/import_memory.py [--rows 10000000] [--wide-columns 200000]
                                                 [--wide-rows 50] [--skip-long] [--skip-wide]
                                                 [--binary-rows 10000000] [--skip-binary]
                                                 [--keep DIR]

Generates the files in a temporary folder (numpy, in chunks, so this script's own memory stays
small), imports each into a scratch raw/ under ``/usr/bin/time -v`` and prints the import's peak
resident set size (the kernel's maximum RSS of the process, ``Maximum resident set size``) and
its wall time, then deletes everything (``--keep DIR`` keeps the files there instead).

- **long**: ``--rows`` rows of four columns (t [s], U [V], I [mA], x [um]) at 50 kHz; the import
  takes t, U and x, so I is a column it must not read;
- **wide**: a header of ``--wide-columns`` columns and ``--wide-rows`` rows; the import takes two of
  them (``--fs``);
- **tdms**, **mat73**: ``--binary-rows`` samples of the long file's U, I and x as float64 channels
  of a TDMS file (group ``DAQ``, written in segments, fs from ``wf_increment``) and as an N×3
  matrix of a v7.3 (HDF5) file (stored transposed and chunked, as MATLAB does); the import takes
  U and x.

The figures go to benchmarks/README.md (command J); the machine's load (``uptime``) is printed with
them, since two shared cores make wall times vary.
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
SELFSENSE = Path(sys.executable).with_name("selfsense")
FS = 50_000.0
BLOCK = 1 << 18


def write_long(path: Path, rows: int) -> None:
    """t [s], U [V], I [mA], x [um]: a 1 Hz sine of ±150 V and its 30 µm stroke, with noise."""
    rng = np.random.default_rng(1)
    with open(path, "w") as out:
        out.write("t [s],U [V],I [mA],x [um]\n")
        for start in range(0, rows, BLOCK):
            k = np.arange(start, min(rows, start + BLOCK))
            t = k / FS
            u = 150 * np.sin(2 * np.pi * t)
            i = 3.0 * np.cos(2 * np.pi * t) + rng.normal(0, 0.01, len(k))
            x = 15 + 15 * np.sin(2 * np.pi * t - 0.12) + rng.normal(0, 0.005, len(k))
            np.savetxt(
                out,
                np.column_stack([t, u, i, x]),
                fmt=["%.8f", "%.4f", "%.5f", "%.5f"],
                delimiter=",",
            )


def write_wide(path: Path, columns: int, rows: int) -> None:
    """A header of ``columns`` names (c0, c1, …) and small integers below it."""
    rng = np.random.default_rng(2)
    with open(path, "w") as out:
        out.write(",".join(f"c{j}" for j in range(columns)) + "\n")
        for _ in range(rows):
            out.write(",".join(map(str, rng.integers(-99, 100, columns))) + "\n")


def long_blocks(rows: int):
    """The long file's U [V], I [mA] and x [µm], a block at a time."""
    rng = np.random.default_rng(1)
    for start in range(0, rows, BLOCK):
        t = np.arange(start, min(rows, start + BLOCK)) / FS
        yield (
            150 * np.sin(2 * np.pi * t),
            3.0 * np.cos(2 * np.pi * t) + rng.normal(0, 0.01, len(t)),
            15 + 15 * np.sin(2 * np.pi * t - 0.12) + rng.normal(0, 0.005, len(t)),
        )


def write_tdms(path: Path, rows: int) -> None:
    from nptdms import ChannelObject, GroupObject, RootObject, TdmsWriter

    waveform = {"wf_increment": 1 / FS}
    with TdmsWriter(path) as writer:
        writer.write_segment([RootObject(), GroupObject("DAQ")])
        for u, i, x in long_blocks(rows):
            writer.write_segment(
                [
                    ChannelObject("DAQ", name, values, waveform)
                    for name, values in (("U", u), ("I", i), ("x", x))
                ]
            )


def write_mat73(path: Path, rows: int) -> None:
    import h5py

    with h5py.File(path, "w", userblock_size=512) as f:
        data = f.create_dataset("data", (3, rows), dtype="f8", chunks=(3, min(rows, BLOCK)))
        data.attrs["MATLAB_class"] = np.bytes_("double")
        start = 0
        for u, i, x in long_blocks(rows):
            data[:, start : start + len(u)] = np.vstack([u, i, x])
            start += len(u)
    with open(path, "r+b") as raw:  # MATLAB's 128-byte text header in the user block
        raw.write(b"MATLAB 7.3 MAT-file".ljust(116) + b"\x00" * 8 + b"\x00\x02IM")


def timed_import(args: list[str], raw: Path) -> dict[str, str]:
    """``selfsense import`` under /usr/bin/time -v: peak RSS [MB], wall [s], exit status."""
    command = ["/usr/bin/time", "-v", str(SELFSENSE), "import", *args, "--raw-dir", str(raw)]
    began = time.monotonic()
    run = subprocess.run(command, capture_output=True, text=True)
    wall = time.monotonic() - began
    rss = re.search(r"Maximum resident set size \(kbytes\): (\d+)", run.stderr)
    user = re.search(r"User time \(seconds\): ([\d.]+)", run.stderr)
    system = re.search(r"System time \(seconds\): ([\d.]+)", run.stderr)
    if run.returncode:
        tail = [line for line in run.stderr.splitlines() if "selfsense import" in line]
        print(f"    the import failed ({run.returncode}): {tail[-1:] or run.stderr[-2000:]}")
    return {
        "peak RSS": f"{int(rss.group(1)) / 1024:.0f} MB" if rss else "?",
        "wall": f"{wall:.1f} s",
        "CPU (user + sys)": f"{float(user.group(1)) + float(system.group(1)):.1f} s"
        if user and system
        else "?",
        "exit": str(run.returncode),
    }


def report(what: str, path: Path, figures: dict[str, str]) -> None:
    size = path.stat().st_size / 1e6
    print(
        f"{what} ({path.name}, {size:.0f} MB): " + ", ".join(f"{k} {v}" for k, v in figures.items())
    )


def main() -> None:
    cli = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    cli.add_argument("--rows", type=int, default=10_000_000)
    cli.add_argument("--wide-columns", type=int, default=200_000)
    cli.add_argument("--wide-rows", type=int, default=50)
    cli.add_argument("--skip-long", action="store_true")
    cli.add_argument("--skip-wide", action="store_true")
    cli.add_argument("--binary-rows", type=int, default=10_000_000)
    cli.add_argument("--skip-binary", action="store_true")
    cli.add_argument("--keep", type=Path, help="keep the generated files and captures here")
    args = cli.parse_args()
    folder = Path(tempfile.mkdtemp(prefix="import_memory_", dir=args.keep))
    print(f"machine: {os.cpu_count()} cores; uptime: {subprocess.getoutput('uptime').strip()}")
    try:
        if not args.skip_long:
            source = folder / "long.csv"
            began = time.monotonic()
            write_long(source, args.rows)
            print(f"wrote {args.rows} rows in {time.monotonic() - began:.0f} s")
            figures = timed_import(
                [
                    str(source),
                    "--dataset",
                    "bench_long",
                    "--experiment",
                    "long",
                    "--time",
                    "t [s]:s",
                    "--channel",
                    "U=U [V]:V",
                    "--channel",
                    "x_laser=x [um]:um",
                ],
                folder / "raw",
            )
            report(f"long: {args.rows} rows, 4 columns, 3 imported", source, figures)
            if not args.keep:
                source.unlink()
        if not args.skip_wide:
            source = folder / "wide.csv"
            write_wide(source, args.wide_columns, args.wide_rows)
            figures = timed_import(
                [
                    str(source),
                    "--dataset",
                    "bench_wide",
                    "--experiment",
                    "wide",
                    "--fs",
                    "1000",
                    "--channel",
                    "U=c1:V",
                    "--channel",
                    f"x_laser=c{args.wide_columns - 1}:um",
                ],
                folder / "raw",
            )
            report(
                f"wide: {args.wide_columns} columns, {args.wide_rows} rows, 2 imported",
                source,
                figures,
            )
        if not args.skip_binary:
            for kind, write, channels in (
                ("tdms", write_tdms, ["U=DAQ/U:V", "x_laser=DAQ/x:um"]),
                ("mat73", write_mat73, ["U=data[1]:V", "x_laser=data[3]:um"]),
            ):
                source = folder / f"long.{'tdms' if kind == 'tdms' else 'mat'}"
                write(source, args.binary_rows)
                extra = [] if kind == "tdms" else ["--fs", str(FS)]
                command = [str(source), "--dataset", f"bench_{kind}", "--experiment", kind]
                for c in channels:
                    command += ["--channel", c]
                figures = timed_import(command + extra, folder / "raw")
                report(
                    f"{kind}: {args.binary_rows} samples, 3 channels, 2 imported", source, figures
                )
                if not args.keep:
                    source.unlink()
        print(f"uptime after: {subprocess.getoutput('uptime').strip()}")
    finally:
        if not args.keep:
            shutil.rmtree(folder, ignore_errors=True)


if __name__ == "__main__":
    main()
