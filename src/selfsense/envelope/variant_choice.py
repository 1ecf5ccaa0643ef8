"""The twin's variants chosen by the data they are not judged on (docs/validation.md, "The
twin's variants").

A variant validation (config.yaml's ``validation.variants``) runs one wave over the prior and
every declared variant's keys (workflow/validation.yaml's ``variants:``); its tables join a base
validation's, whose runs hold every variant off (``validation.joins``). One set of emulators is
fitted on all the runs over all the inputs, and a *model* is the prior candidates with some of
them held (:func:`selfsense.envelope.campaign.variant_models`): today's twin with every
variant's keys at their off value (the nominal, the term off), a variant with its own keys
free, the others off and what it holds at its nominal, all variants with every key free. For
each model every fold is predicted from the other folds and the common targets exactly as the
base validation predicts it (:func:`selfsense.envelope.fold_prediction.predict_folds`: the same
cut, variances and quantiles), and the fold-compatibility map is made. So a mechanism wins a
fold only where folds it is not judged on leave it room.

A fold *holds* under a model when none of its findings is inconsistent or incompatible, *fails*
when one is, and is *not judged* when no finding gets a verdict (not emulable, no verdict). A
variant **reconciles** a fold today's twin fails and it holds, **breaks** one today's twin holds
and it fails, and is **supported** when it reconciles some fold and breaks none (the
declaration's ``variants.adopt``).

Frames and text out; nothing is read or written.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import pandas as pd

from selfsense.envelope.campaign import TODAY, Model
from selfsense.envelope.emulator import Settings
from selfsense.envelope.fold_prediction import (
    INCOMPATIBLE,
    INCONSISTENT,
    NOT_EMULABLE,
    compatibility,
    declared_columns,
    predict_folds,
)
from selfsense.envelope.history_matching import nuggets, predict_all, prior_candidates, streams
from selfsense.envelope.judgement import (
    emulable_of,
    emulate,
    emulators_of,
    ensemble,
    findings,
    held_points,
    one_blas_thread,
    replicate_variance,
    verdict_table,
)
from selfsense.scorecard.registry import Entry

#: a fold's state under a model
HOLDS, FAILS, NOT_JUDGED = "holds", "fails", "not judged"
#: the verdicts that make a fold fail
FAILING = (INCONSISTENT, INCOMPATIBLE)


@dataclass(frozen=True)
class Choice:
    """Per model: every emergent row's verdict (long, a ``model`` column first), the
    fold-compatibility maps (long), each fold's state, the declared rows side by side, and the
    summary."""

    verdicts: pd.DataFrame
    compatibility: pd.DataFrame
    folds: pd.DataFrame
    rows: pd.DataFrame
    summary: str


@one_blas_thread
def choose(
    declaration,
    entries: Sequence[Entry],
    ids: Sequence[str],
    inputs: pd.DataFrame,
    rows: pd.DataFrame,
    targets: pd.DataFrame,
    chosen: Sequence[Model],
) -> Choice:
    """Every model of ``chosen`` judged on one set of emulators of the joined tables (module
    docstring), with one BLAS thread."""
    s = declaration.settings
    seed = int(s["waves"]["seed"])
    ens = ensemble(declaration, ids, inputs, rows, targets)
    columns = declared_columns(declaration)
    var, df = replicate_variance(ens.Y, ens.wave, ens.point)
    fitted = emulate(
        ens.X, ens.Y, Settings.from_declaration(s["emulator"], seed), var, df, columns.judged
    )
    emulators = emulators_of(fitted)
    var_ens = nuggets(emulators)
    points = prior_candidates(int(s["prediction"]["samples"]), len(ids), streams(seed).candidates)
    kw = {"cutoff": declaration.cutoff, "second_maximum_from": declaration.second_maximum_from}
    verdicts, maps = [], []
    for m in chosen:
        mean, var_em = predict_all(emulators, held_points(points, ids, m.fixed))
        preds = predict_folds(
            columns, mean, var_em, var_ens, quantiles=s["prediction"]["quantiles"], **kw
        )
        table = verdict_table(
            declaration, entries, columns, preds, fitted, emulable_of(mean), [""] * len(fitted)
        )
        verdicts.append(table.drop(columns="driven by").assign(model=m.name))
        folds, share = compatibility(columns, mean, var_em, var_ens, **kw)
        maps.append(pd.DataFrame(share, columns=folds).assign(model=m.name, fold=folds))
    verdicts = pd.concat(verdicts, ignore_index=True)
    verdicts = verdicts[["model", *[c for c in verdicts.columns if c != "model"]]]
    maps = pd.concat(maps, ignore_index=True)
    maps = maps[["model", "fold", *[c for c in maps.columns if c not in ("model", "fold")]]]
    states = fold_states(verdicts, [m.name for m in chosen])
    selected = side_by_side(verdicts, s["variants"].get("rows", {}).get("select", ()))
    return Choice(verdicts, maps, states, selected, summary(states, maps, len(ens.members)))


def fold_states(verdicts: pd.DataFrame, names: Sequence[str]) -> pd.DataFrame:
    """folds × models: each fold's state (module docstring), its findings only (a row's
    algebraic twins go with it)."""
    own = findings(verdicts)
    judged = own[~own["verdict"].isin([NOT_EMULABLE, "no verdict"])]
    out = {}
    for name in names:
        part = judged[judged["model"] == name]
        failing = set(part.loc[part["verdict"].isin(FAILING), "fold"])
        seen = set(part["fold"])
        folds = list(dict.fromkeys(own["fold"]))
        out[name] = [FAILS if f in failing else HOLDS if f in seen else NOT_JUDGED for f in folds]
    return pd.DataFrame(out, index=pd.Index(list(dict.fromkeys(own["fold"])), name="fold"))


def reconciled(states: pd.DataFrame, name: str) -> tuple[list[str], list[str]]:
    """(the folds model ``name`` reconciles, the folds it breaks) against today's twin."""
    today, its = states[TODAY], states[name]
    return (
        list(states.index[(today == FAILS) & (its == HOLDS)]),
        list(states.index[(today == HOLDS) & (its == FAILS)]),
    )


def side_by_side(verdicts: pd.DataFrame, select: Sequence[Mapping[str, str]]) -> pd.DataFrame:
    """The selected rows' verdict and posterior-predictive interval under every model."""
    keys = [(r["source"], r["quantity"]) for r in select]
    pick = verdicts[[k in keys for k in zip(verdicts["source"], verdicts["quantity"])]]
    return pick[
        [
            "model",
            "fold",
            "source",
            "quantity",
            "unit",
            "published",
            "p2.5",
            "p50",
            "p97.5",
            "implausibility",
            "verdict",
        ]
    ].reset_index(drop=True)


def summary(states: pd.DataFrame, maps: pd.DataFrame, runs: int) -> str:
    """Per model: the folds it holds, fails and cannot judge, those it reconciles and breaks
    against today's twin, the pairs of folds its map says cannot hold together, and whether it
    is supported (module docstring)."""
    lines = [f"The twin's variants judged on {runs} runs (today's twin's and the variants')."]
    for name in states.columns:
        state = states[name]
        folds = [c for c in maps.columns if c not in ("model", "fold")]
        share = maps[maps["model"] == name].set_index("fold")[folds]
        pairs = [
            f"{a}–{b}"
            for i, a in enumerate(folds)
            for b in folds[i + 1 :]
            if share.loc[a, b] == 0 and share.loc[a, a] > 0 and share.loc[b, b] > 0
        ]
        line = (
            f"{name}: holds {int((state == HOLDS).sum())}, fails {int((state == FAILS).sum())} "
            f"({', '.join(state.index[state == FAILS]) or 'none'}), not judged "
            f"{int((state == NOT_JUDGED).sum())} folds; pairs that cannot hold together: "
            f"{', '.join(pairs) or 'none'}"
        )
        if name != TODAY:
            won, lost = reconciled(states, name)
            line += (
                f"; reconciles {', '.join(won) or 'none'}, breaks {', '.join(lost) or 'none'}: "
                + ("supported" if name in supported(states) else "not supported")
            )
        lines += ["", line + "."]
    return "\n".join(lines) + "\n"


def supported(states: pd.DataFrame) -> list[str]:
    """The models (not today's twin) that reconcile some fold and break none."""
    out = []
    for name in states.columns:
        won, lost = reconciled(states, name) if name != TODAY else ([], [])
        if won and not lost:
            out.append(name)
    return out
