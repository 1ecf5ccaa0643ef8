"""The ``selfsense`` command: ``selfsense import`` turns a lab's recording into a capture and
its dataset's manifest (docs/bring-your-own-data.md)."""

from __future__ import annotations

import argparse
import logging
import sys
from pathlib import Path

from selfsense.io.audit import report as audit_report
from selfsense.io.capture import CaptureError
from selfsense.io.importer import (
    ImportProblem,
    Request,
    parse_attr,
    parse_column,
    parse_range,
    run_import,
)
from selfsense.io.manifest import ManifestError

EXAMPLE = """\
worked example (a 1 Hz, ±150 V sine at 5 kHz: columns t [s], U [V], x [µm]):

  selfsense import sine_1hz.csv --dataset my_stack --experiment sine_1hz \\
      --time t:s --channel U=U:V --channel x_laser=x:um
  snakemake --cores 2 --config 'datasets=[my_stack]'

writes raw/my_stack/sine_1hz.nc and raw/my_stack/dataset.yaml (scaffolded, or updated when the
dataset exists); then results/my_stack/characterise/summary.csv and
figures/my_stack/characterise/loops_01.png. Columns go by name or by index (x_laser=2:um); \
a .mat file
names its variables (U=rec.Y[0].Data:V, x_laser=data[1]:um). Units are converted to the
contract's (V, A, m, N); channels: U, I, x_laser or x_disp, F, Ur, Ir, ... \
(docs/capture-contract.md).

Everything is checked before the capture appears, and a refusal is one line naming the file or
the argument (exit 1) that leaves nothing behind: no capture, no temporary, no manifest change.
A CSV is read in chunks, only the columns asked for, twice (check, then write): memory does not
grow with its length; a .mat file is loaded whole. Data rows that end in the separator while the
header does not keep their columns. Overload values (|v| >= 1e30, e.g. 9.9E+37, or +-inf) are
stored as missing and counted (the capture's import_note), before a range is derived; a channel
overloaded in more than 1 % of its samples, or without a single value, is refused. Imports into
one dataset run one after another (its lock, raw/<dataset>/.import.lock); an existing capture is
never overwritten.
"""


def _arg(parse):
    """argparse shows an ArgumentTypeError's own message (a ValueError only as "invalid value")."""

    def wrapped(text):
        try:
            return parse(text)
        except ImportProblem as err:
            raise argparse.ArgumentTypeError(str(err)) from None

    wrapped.__name__ = parse.__name__
    return wrapped


def parser() -> argparse.ArgumentParser:
    cli = argparse.ArgumentParser(prog="selfsense", description=__doc__)
    commands = cli.add_subparsers(dest="command", required=True)
    imp = commands.add_parser(
        "import",
        help="a CSV/TSV or .mat recording into raw/<dataset>/",
        description="Import one recording as one capture of a measured dataset (names: at "
        "most 100 characters).",
        epilog=EXAMPLE,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    imp.add_argument(
        "source", type=Path, help="the recording: .csv, .tsv (or --sep) or .mat (v4–v7)"
    )
    imp.add_argument("--dataset", required=True, help="dataset name: letters, digits, '_' or '-'")
    imp.add_argument("--experiment", required=True, help="capture name: letters, digits or '_'")
    imp.add_argument(
        "--channel",
        action="append",
        required=True,
        type=_arg(parse_column),
        dest="channels",
        metavar="CHANNEL=COLUMN:UNIT",
        help="a contract channel, where it is, its unit there",
    )
    timing = imp.add_mutually_exclusive_group()
    timing.add_argument(
        "--time",
        type=_arg(lambda t: parse_column(t, time=True)),
        metavar="COLUMN:UNIT",
        help="the time column (s, ms, us): fs from the least-squares line through it, every "
        "sample within a quarter sample of that line",
    )
    timing.add_argument(
        "--fs", type=float, help="sampling rate [Hz], finite and > 0, when there is no time column"
    )
    imp.add_argument(
        "--range",
        action="append",
        type=_arg(parse_range),
        dest="ranges",
        metavar="CHANNEL=LOW,HIGH",
        help="the ADC's full scale in the contract's unit (default: the manifest's, else "
        "derived from the data)",
    )
    imp.add_argument(
        "--attr",
        action="append",
        type=_arg(parse_attr),
        dest="attrs",
        metavar="NAME=VALUE",
        help="a capture attribute, e.g. warmup_s=0.5 (docs/capture-contract.md)",
    )
    imp.add_argument(
        "--sep",
        help="column separator, one character that is not part of a number ('\\t' for a tab; "
        "default: tab for .tsv, else comma)",
    )
    imp.add_argument(
        "--no-header", dest="header", action="store_false", help="the file has no header row"
    )
    imp.add_argument(
        "--model", choices=["stack", "bender", "other"], help="the actuator's kind (new datasets)"
    )
    imp.add_argument(
        "--raw-dir", type=Path, default=Path("raw"), help="where datasets live (default: raw)"
    )
    _add_audit(commands)
    return cli


def _add_audit(commands) -> None:
    audit = commands.add_parser(
        "audit",
        help="whether outputs still describe their inputs (sha256 in their provenance)",
        description="Compare the sha256 each output's provenance recorded for its inputs with "
        "the inputs now; one line per stale input with how to re-make it, or '<output>: up to "
        "date (<n> inputs)'. Exit 1 if anything is stale or has no readable provenance, else 0 "
        "(docs/auditing.md).",
    )
    audit.add_argument(
        "outputs",
        nargs="+",
        type=Path,
        metavar="OUTPUT",
        help="a table, figure or JSON report, or a folder (results/<dataset>): every output in it",
    )
    audit.add_argument(
        "--root",
        type=Path,
        default=Path("."),
        help="the checkout the outputs were made in: recorded inputs are relative to it "
        "(default: the current directory)",
    )


def _audit(args: argparse.Namespace) -> int:
    lines, stale = audit_report(args.outputs, args.root)
    print("\n".join(lines))
    return 1 if stale else 0


def main(argv: list[str] | None = None) -> int:
    logging.basicConfig(level=logging.INFO, format="%(message)s", stream=sys.stderr)
    try:
        args = parser().parse_args(argv)
        if args.command == "audit":
            return _audit(args)
        capture, manifest = run_import(
            Request(
                args.source,
                args.dataset,
                args.experiment,
                tuple(args.channels),
                args.time,
                args.fs,
                dict(args.ranges or ()),
                dict(args.attrs or ()),
                args.sep,
                args.header,
                args.model,
                args.raw_dir,
            )
        )
    except (ImportProblem, CaptureError, ManifestError) as err:
        print(f"selfsense import: {err}", file=sys.stderr)
        return 1
    print(f"wrote {capture} and {manifest}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
