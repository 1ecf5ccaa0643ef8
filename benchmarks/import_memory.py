"""Peak memory and wall time of `selfsense import` on a long and on a wide CSV.

    .venv/bin/python benchmarks/import_memory.py [--rows 10000000] [--wide-columns 200000]
                                                 [--wide-rows 50] [--skip-long] [--skip-wide]
                                                 [--keep DIR]

Generates the files in a temporary folder (numpy, in chunks, so this script's own memory stays
small), imports each into a scratch raw/ under ``/usr/bin/time -v`` and prints the import's peak
resident set size (the kernel's maximum RSS of the process, ``Maximum resident set size``) and
its wall time, then deletes everything (``--keep DIR`` keeps the files there instead).

- **long**: ``--rows`` rows of four columns (t [s], U [V], I [mA], x [um]) at 50 kHz; the import
  takes t, U and x, so I is a column it must not read;
- **wide**: a header of ``--wide-columns`` columns and ``--wide-rows`` rows; the import takes two of
  them (``--fs``).

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
        print(f"uptime after: {subprocess.getoutput('uptime').strip()}")
    finally:
        if not args.keep:
            shutil.rmtree(folder, ignore_errors=True)


if __name__ == "__main__":
    main()
