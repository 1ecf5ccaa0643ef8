"""The ``selfsense`` command: ``selfsense import`` turns a lab's recording into a capture and
its dataset's manifest (docs/bring-your-own-data.md)."""

from __future__ import annotations

import argparse
import logging
import sys
from pathlib import Path

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
        description="Import one recording as one capture of a measured dataset.",
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
        help="the time column (s, ms, us); checked to be uniformly sampled",
    )
    timing.add_argument("--fs", type=float, help="sampling rate [Hz] when there is no time column")
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
    imp.add_argument("--sep", help="column separator (default: tab for .tsv, else comma)")
    imp.add_argument(
        "--no-header", dest="header", action="store_false", help="the file has no header row"
    )
    imp.add_argument(
        "--model", choices=["stack", "bender", "other"], help="the actuator's kind (new datasets)"
    )
    imp.add_argument(
        "--raw-dir", type=Path, default=Path("raw"), help="where datasets live (default: raw)"
    )
    return cli


def main(argv: list[str] | None = None) -> int:
    logging.basicConfig(level=logging.INFO, format="%(message)s", stream=sys.stderr)
    try:
        args = parser().parse_args(argv)
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
