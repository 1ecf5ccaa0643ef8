"""The ``selfsense`` command: ``selfsense import`` turns a lab's recording into a capture and
its dataset's manifest (docs/bring-your-own-data.md)."""

from __future__ import annotations

import argparse
import logging
import sys
from pathlib import Path

from selfsense.io.audit import report as audit_report
from selfsense.io.capture import CaptureError
from selfsense.io.importer import Request, run_import
from selfsense.io.manifest import ManifestError
from selfsense.io.sources import (
    ImportProblem,
    parse_attr,
    parse_column,
    parse_factor,
    parse_range,
    scalings,
)

EXAMPLE = """\
worked example (a 1 Hz, ±150 V sine at 5 kHz: columns t [s], U [V], x [µm]):

  selfsense import sine_1hz.csv --dataset my_stack --experiment sine_1hz \\
      --time t:s --channel U=U:V --channel x_laser=x:um
  snakemake --cores 2 --config 'datasets=[my_stack]'

writes raw/my_stack/sine_1hz.nc and raw/my_stack/dataset.yaml (scaffolded, or updated when the
dataset exists); then results/my_stack/characterise/summary.csv and
figures/my_stack/characterise/loops_sine_1hz.png.

a DAQ's file without header or time (tab-separated, 200 Hz; column 2 the amplifier's 1/20
monitor of U, column 6 a displacement sensor's volts at 10 µm/V):

  selfsense import run3.txt --dataset my_stack --experiment sine_1hz --no-header --fs 200 \\
      --channel U=2:V --gain U=20 --channel x_disp=6:um --scale x_disp=10

Columns go by header name or by position counted from 1 (x_laser=3:um is the third column):
digits are always a position; a header name made of digits is written with '#' (U=#2:V, the
column named 2). A .mat file names its variables, v4 to v7.3 (U=rec.Y[1].Data:V,
x_laser=data[2]:um: [k] counted from 1, data[2] is MATLAB's data(:,2)); a .tdms file its
channels as Group/Channel (U='Untitled/Dev1/ai0':V), by the channel's name alone where no other
group has it, or by position counted from 1; a TDMS channel's wf_increment gives fs when neither
--time nor --fs does (given, they must agree with it). Units are converted to the contract's (V,
A, m, N), then multiplied by --scale or --gain; channels: U, I, x_laser or x_disp, F, Ur, Ir, ...
(docs/capture-contract.md). Without --sep, a file other than .tsv is split at whichever of tab,
';' and ',' splits its first lines alike (logged).

Everything is checked before the capture appears, and a refusal is one line naming the file or
the argument (exit 1), and what to type instead where it can, that leaves nothing behind: no
capture, no temporary, no manifest change. A column that holds one value throughout (a position
counted from 0?) is refused, naming the columns that vary. On a first import (no --range, no
range in the manifest) a channel's range must be one a piezo bench records: a voltage within
+-10 kV, a current within +-100 A, a force within +-1 MN, a displacement spanning 0.1 nm to 1 cm;
else the refusal names the unit that fits (x_disp spans 49.4 m: ... type x_disp=6:um) or --range
to keep it. A CSV, TDMS or v7.3 file is read in chunks, only the columns asked for, twice
(check, then write): memory does not grow with its length; a v4-v7 .mat file is loaded whole.
Data rows that end in the separator while the header does not keep their columns. Overload
values (|v| >= 1e30, e.g. 9.9E+37, or +-inf) are stored as missing and counted (the capture's
import_note), before a range is derived; a channel overloaded in more than 1 % of its samples,
or without a single value, is refused; so is one column named for two channels, a --gain or
--scale that leaves a channel fewer than 64 int16 codes of its range, and a v7.3 variable
declared longer than the samples written (a TDMS file whose last segment was cut is cut to the
samples it holds, and says so). Imports into one dataset run one after another (its lock,
raw/<dataset>/.import.lock); an existing capture is never overwritten.
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
        help="a CSV/TSV, .mat or .tdms recording into raw/<dataset>/",
        description="Import one recording as one capture of a measured dataset (names: at "
        "most 100 characters).",
        epilog=EXAMPLE,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    imp.add_argument(
        "source",
        type=Path,
        help="the recording: .csv, .tsv, .txt (any text: the separator detected, or --sep), .mat "
        "(v4–v7.3) or .tdms",
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
        help="a contract channel, where it is, its unit there. COLUMN: a header name, or a "
        "position counted from 1 (digits are always a position; '#7' is the header's column "
        "named 7); a .mat variable (rec.Y, data[1] = MATLAB's data(:,1)); a .tdms channel "
        "(Group/Channel, its name alone, or a position counted from 1)",
    )
    timing = imp.add_mutually_exclusive_group()
    timing.add_argument(
        "--time",
        type=_arg(lambda t: parse_column(t, time=True)),
        metavar="COLUMN:UNIT",
        help="the time column (s, ms, us), as --channel's COLUMN: fs from the least-squares line "
        "through it, every sample within a quarter sample of that line",
    )
    timing.add_argument(
        "--fs",
        type=float,
        help="sampling rate [Hz], finite and > 0, when there is no time column (a .tdms file: "
        "default 1/wf_increment of its channels, which --fs or --time must agree with to 1e-6)",
    )
    imp.add_argument(
        "--scale",
        action="append",
        type=_arg(parse_factor),
        dest="scales",
        metavar="CHANNEL=FACTOR",
        help="a sensor's sensitivity: the recorded column times FACTOR is the channel in "
        "--channel's unit (x_disp=10: a sensor logged in V at 10 µm/V, with x_disp=6:um); "
        "finite, nonzero; recorded as the capture's scale_<channel> and the manifest's "
        "sensors.<channel>.scale (scale_kind: sensitivity)",
    )
    imp.add_argument(
        "--gain",
        action="append",
        type=_arg(lambda t: parse_factor(t, "--gain")),
        dest="gains",
        metavar="CHANNEL=FACTOR",
        help="an amplifier's gain or a monitor output's ratio: the recorded column times FACTOR "
        "is the channel (U=20: the DAQ logged the amplifier's 1/20 monitor); negative for an "
        "inverting amplifier; recorded as --scale is (scale_kind: gain). A dataset's captures "
        "share one factor per channel",
    )
    imp.add_argument(
        "--range",
        action="append",
        type=_arg(parse_range),
        dest="ranges",
        metavar="CHANNEL=LOW,HIGH",
        help="the ADC's full scale in the contract's unit, after --scale/--gain (default: the "
        "manifest's, else derived from the data and checked against what a piezo bench records)",
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
        help="column separator, one character that is not part of a number (tab or '\\t' for a "
        "tab; default: tab for .tsv, else whichever of tab, ';' and ',' splits the first lines "
        "alike)",
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
                scales=scalings(args.scales or (), args.gains or ()),
            )
        )
    except (ImportProblem, CaptureError, ManifestError) as err:
        print(f"selfsense import: {err}", file=sys.stderr)
        return 1
    print(f"wrote {capture} and {manifest}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
