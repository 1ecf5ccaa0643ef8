"""Search the digital twin's free parameters for values that meet its calibration signatures.

The signatures, their bands and the free parameters with their search ranges are
workflow/twin_calibration.yaml (docs/twin.md, "Calibration"); nothing else is fitted to. For each
trial the twin runs the short experiments of selfsense.verify.signatures (a campaign's own protocols
for the Chapter 3–6 runs; the steady temperature and τ by the thermal model's closed forms, not a
600 s run), the pipeline's analysis functions measure them, and the targets judge them as rule
twin_calibration judges a campaign. scipy.optimize.least_squares minimises each signature's
distance to its band in band widths (0 inside a band narrowed by a tenth of its width at each
edge, so that what is found holds over the instruments' noise), over the free parameters scaled
to [0, 1] (on a log scale for those spanning a decade or more). The runs follow the thesis
campaign's protocols, so at the manifest's values and seed they are the campaign's own captures
and give its numbers; the smoke campaign's are faster but too short for the loop widths, whose
two cycles there are mostly noise.

It prints, in order:
  1. the signatures at the manifest's values (± their spread over --seeds seeds of the
     instruments' noise);
  2. how much each free parameter moves each signature (a tenth of its range);
  3. every signature out of its band searched alone, moving the parameters that move it (a tenth
     of a range moving it by 5 % of its band or more): one the search does not bring into its band
     is left out of what follows (a local search: the sensitivities and the spread over noise
     seeds of 1. and 2. say whether another region could, and whether that would mean anything);
  4. the joint search of the others: the values found, and the signatures there;
  5. for each signature the joint search leaves out of its band, a search from there that weighs it
     ten times more, moving the parameters that move it: the signatures that are then out of their
     bands are those it cannot be met together with.

    .venv/bin/python scripts/calibrate_twin.py                      # pi_p885
    .venv/bin/python scripts/calibrate_twin.py --free thermal.k_T   # move k_T only
    .venv/bin/python scripts/calibrate_twin.py --write raw/<dataset>/dataset.yaml

--write puts the values found into that manifest's twin block, with a comment line that names
this script. A search takes about two minutes on one core.
"""

import argparse
import dataclasses
import math
import re
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd
from scipy.optimize import least_squares

from selfsense.io.manifest import ManifestError, expand_protocols, load_config, load_dataset
from selfsense.methods.electromech import geometry_from_actuator
from selfsense.scorecard.calibration import calibration_table, load_targets
from selfsense.twin.experiment import daq_plan
from selfsense.twin.params import TwinParams
from selfsense.verify.signatures import TABLES, ShortRuns

#: a trial whose signature is not a number (an identification that fails at the edge of a
#: range) counts as this many band widths out
UNMEASURED = 10.0
#: the step of the sensitivity table and of least squares' finite differences, in parameter ranges
STEP, DIFF_STEP = 0.1, 0.02
#: the search aims this far inside each band (in band widths), and weighs a signature it favours so
MARGIN, FAVOUR = 0.1, 10.0
#: a parameter moves a signature when a tenth of its range moves it by this much of its band: the
#: short runs' noise moves the loop widths about that much, so a smaller effect is no handle on it
MOVES = 0.05
#: a search for one signature alone is cheap (its own runs only): it may iterate this many times
#: more
ALONE = 4
WRITTEN = (
    "# twin: {names} found by scripts/calibrate_twin.py against workflow/twin_calibration.yaml"
)


class Search:
    """The free parameters on the unit cube, and the targets' distances to their bands at a
    point."""

    def __init__(self, params, free, targets, runs):
        self.params, self.free, self.runs, self.targets = params, free, runs, targets
        self.log = [name for name, (low, high) in free.items() if low > 0 and high / low >= 10]

    def values(self, u):
        """{name: value} at the point u of the unit cube."""
        return {
            name: (
                math.exp(math.log(low) + x * math.log(high / low))
                if name in self.log
                else low + x * (high - low)
            )
            for (name, (low, high)), x in zip(self.free.items(), u)
        }

    def point(self, values):
        return np.array(
            [
                (
                    math.log(values[n] / low) / math.log(high / low)
                    if n in self.log
                    else (values[n] - low) / (high - low)
                )
                for n, (low, high) in self.free.items()
            ]
        ).clip(0, 1)

    def twin(self, values):
        params = self.params
        for name, value in values.items():
            section, key = name.split(".")
            params = dataclasses.replace(
                params, **{section: dataclasses.replace(getattr(params, section), **{key: value})}
            )
        return params

    def table(self, values, targets=None, runs=None):
        """The targets' calibration table at ``values``, from only the runs they need."""
        targets = self.targets if targets is None else targets
        tables = (runs or self.runs).tables(self.twin(values), {t.locate.table for t in targets})
        return calibration_table(targets, tables)

    def distances(self, u, targets, weights):
        values = self.table(self.values(u), targets)["twin value"].astype(float)
        return np.array(
            [
                w * (t.distance(v, MARGIN) if np.isfinite(v) else UNMEASURED)
                for t, v, w in zip(targets, values, weights)
            ]
        )

    def fit(self, u0, targets, max_nfev, favour=None, moving=None):
        """The point least squares reaches from u0 moving the parameters ``moving`` (indices; all by
        default) and weighing the target ``favour`` FAVOUR times the others, and whether it stopped
        for lack of iterations."""
        moving = list(range(len(u0))) if moving is None else list(moving)
        weights = [FAVOUR if t is favour else 1.0 for t in targets]

        def distances(x):
            u = u0.copy()
            u[moving] = x
            return self.distances(u, targets, weights)

        found = least_squares(
            distances, u0[moving], bounds=(0, 1), diff_step=DIFF_STEP, max_nfev=max_nfev
        )
        u = u0.copy()
        u[moving] = found.x
        return u, found.status == 0

    def sensitivity(self, u0, start):
        """{parameter: change of each signature} when the parameter moves by STEP of its range."""
        out = {}
        for j, name in enumerate(self.free):
            u = u0.copy()
            u[j] += STEP if u[j] + STEP <= 1 else -STEP
            moved = self.table(self.values(u))["twin value"].to_numpy(float)
            out[name] = (moved - start["twin value"].to_numpy(float)) * np.sign(u[j] - u0[j])
        return pd.DataFrame(out, index=[t.id for t in self.targets])


def check_free(free, params, source):
    for name in free:
        section, key = name.split(".")
        part = getattr(params, section, None)
        if (
            part is None
            or key not in {f.name for f in dataclasses.fields(part)}
            or not isinstance(getattr(part, key), (int, float))
        ):
            raise ManifestError(
                f"{source}: key free.{name}: not a number of the twin's parameters "
                "(a manifest's twin.<section>.<key>)"
            )


def write_manifest(path, values):
    """The values into the manifest's twin block, each on its own line, with the comment line."""
    names, values = sorted(values), dict(values)
    lines = [
        line
        for line in Path(path).read_text(encoding="utf-8").splitlines()
        if not line.startswith(WRITTEN.split("{")[0])
    ]
    block = section = None
    for i, line in enumerate(lines):
        if re.match(r"[^\s#]", line):
            block, section = line.split(":")[0], None
        elif block == "twin" and (m := re.match(r"  (\w+):\s*(#.*)?$", line)):
            section = m.group(1)
        elif block == "twin" and (m := re.match(r"(    (\w+):\s*)([^#]*?)(\s*#.*)?$", line)):
            if f"{section}.{m.group(2)}" in values:
                lines[i] = (
                    f"{m.group(1)}{values.pop(f'{section}.{m.group(2)}'):.4g}{m.group(4) or ''}"
                )
    if values or "twin:" not in lines:
        raise ManifestError(f"{path}: key twin.{next(iter(values), '')} not found to write")
    lines.insert(lines.index("twin:"), WRITTEN.format(names=", ".join(names)))
    Path(path).write_text("\n".join(lines) + "\n", encoding="utf-8")


def show(table, spread=None):
    shown = table[["thesis value", "band low", "band high", "twin value", "within"]].copy()
    if spread is not None:
        shown["± over seeds"] = spread.to_numpy()
    return shown.to_string(float_format=lambda v: f"{v:.4g}")


def assignments(values):
    return ", ".join(f"{n} = {v:.4g}" for n, v in values.items())


def main(dataset, raw, config, targets, campaign, free, seeds, max_nfev, write):
    manifest = load_dataset(raw, dataset)
    params = TwinParams.from_manifest(manifest["twin"], f"{raw}/{dataset}/dataset.yaml: twin")
    calibration = load_targets(targets)
    unknown = [n for n in free or () if n not in calibration.free]
    if unknown:
        raise ManifestError(f"{targets}: --free {unknown[0]} is not one of its free parameters")
    chosen = {n: calibration.free[n] for n in free or calibration.free}
    check_free(chosen, params, targets)
    for t in calibration.targets:
        if t.locate.table not in TABLES:
            print(f"{t.id}: no short run gives {t.locate.table}; not searched")
    cfg = load_config(config)
    with tempfile.TemporaryDirectory() as scratch:

        def runs(protocols, seed=manifest.get("seed", 0)):
            return ShortRuns(
                daq_plan(manifest),
                expand_protocols(manifest["protocols"], protocols),
                geometry_from_actuator(manifest["actuator"]),
                float(manifest["actuator"]["moving_mass_kg"]),
                seed,
                cfg["ripple"]["n_periods"],
                cfg["control"]["omega_c"],
                Path(scratch),
            )

        search = Search(
            params,
            chosen,
            [t for t in calibration.targets if t.locate.table in TABLES],
            runs(campaign),
        )
        ids = [t.id for t in search.targets]
        start = {n: getattr(getattr(params, n.split(".")[0]), n.split(".")[1]) for n in chosen}
        u0 = search.point(start)

        def measured(values):
            """The table at ``values`` on the dataset's seed, and each value's spread over the
            seeds."""
            table = search.table(values)
            repeats = [
                search.table(values, runs=runs(campaign, s))["twin value"] for s in range(1, seeds)
            ]
            return table, pd.concat([table["twin value"], *repeats], axis=1).std(
                axis=1
            ) if repeats else None

        first, spread = measured(start)
        print(
            f"{dataset}, {campaign} protocols, at the manifest's values:\n"
            f"{show(first.set_axis(ids), spread)}\n"
        )
        effect = search.sensitivity(u0, first)
        print(
            f"change of each signature when a parameter moves by {STEP:.0%} of its range:\n"
            f"{effect.to_string(float_format=lambda v: f'{v:.3g}')}\n"
        )
        moves = (
            effect.abs().div(pd.Series({t.id: t.high - t.low for t in search.targets}), axis=0)
            >= MOVES
        )

        def movers(target):
            return [j for j, name in enumerate(chosen) if moves.loc[target.id, name]]

        reachable = []
        for t, ok in zip(search.targets, first["within"]):
            if ok:
                reachable.append(t)
                continue
            if not movers(t):
                print(
                    f"{t.id} alone: out of reach: no free parameter moves it by "
                    f"{MOVES:.0%} of its band; "
                    "left out of the joint search"
                )
                continue
            point, stopped = search.fit(u0, [t], ALONE * max_nfev, moving=movers(t))
            values = search.values(point)
            value = search.table(values, [t])["twin value"].iloc[0]
            if t.within(value):
                reachable.append(t)
                print(f"{t.id} alone: met, {value:.4g} {t.unit}, at {assignments(values)}")
            else:
                print(
                    f"{t.id} alone: not met; least squares from the manifest's values "
                    + ("stops after its iterations" if stopped else "converges")
                    + f" at {value:.4g} {t.unit} "
                    f"(band {t.low:g}–{t.high:g}), moving "
                    f"{', '.join(n for j, n in enumerate(chosen) if j in movers(t))}; "
                    "left out of the joint search"
                )

        u, _ = search.fit(u0, reachable, max_nfev)
        found = search.values(u)
        table, spread = measured(found)
        table = table.set_axis(ids)
        print(
            f"\njoint search of {', '.join(t.id for t in reachable)}:\n"
            + pd.DataFrame(
                {
                    "start": start,
                    "found": found,
                    "low": {n: b[0] for n, b in chosen.items()},
                    "high": {n: b[1] for n, b in chosen.items()},
                }
            ).to_string(float_format=lambda v: f"{v:.4g}")
            + f"\n\nat the values found:\n{show(table, spread)}\n"
        )
        missed = [t for t in reachable if not table.loc[t.id, "within"]]
        print(f"met together: {', '.join(t.id for t in reachable if t not in missed) or 'none'}")
        for t in missed:
            point, _ = search.fit(u, reachable, max_nfev, favour=t, moving=movers(t))
            favoured = search.table(search.values(point), reachable).set_axis(
                [r.id for r in reachable]
            )
            lost = [r for r in favoured.index if not favoured.loc[r, "within"] and r != t.id]
            print(
                f"{t.id}, favoured: {'met' if favoured.loc[t.id, 'within'] else 'still not met'}"
                f" ({favoured.loc[t.id, 'twin value']:.4g} {t.unit}); "
                f"out of their bands then: {', '.join(lost) or 'none'}"
            )
    if write:
        write_manifest(write, found)
        load_dataset(Path(write).parent.parent, Path(write).parent.name)
        print(f"wrote {', '.join(found)} into {write}")


if __name__ == "__main__":
    cli = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    cli.add_argument("--dataset", default="pi_p885")
    cli.add_argument("--raw", default="raw")
    cli.add_argument("--config", default="config.yaml", help="the ripple's np and Chapter 6's ω_C")
    cli.add_argument("--targets", default="workflow/twin_calibration.yaml")
    cli.add_argument("--campaign", default="thesis", help="whose protocols the short runs follow")
    cli.add_argument("--free", nargs="+", help="move only these of the targets' free parameters")
    cli.add_argument(
        "--seeds", type=int, default=3, help="noise seeds the values found are measured with"
    )
    cli.add_argument(
        "--max-nfev", type=int, default=5, help="least-squares iterations of each search"
    )
    cli.add_argument("--write", help="a dataset.yaml to write the values found into")
    main(**vars(cli.parse_args()))
