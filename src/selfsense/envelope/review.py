"""The reviewer's table: every emergent row under the project's three judges side by side.

- the **nominal** twin against the row's registry band (the scorecard: ``verdict``);
- the **prior envelope**: what the declared ranges of the unknowns give, the members' 2.5–97.5 %
  and its verdict (:mod:`selfsense.envelope.verdicts`);
- the **posterior predictive** of the validation: what the other folds and the common targets
  leave, its 2.5/50/97.5 %, the published value's implausibility, its verdict and drivers
  (:mod:`selfsense.envelope.judgement`).

Frames in, a frame out; nothing is read or written. A row one judge has no number for keeps its
other columns (an envelope that did not run a chapter, a scorecard of another campaign).
"""

from __future__ import annotations

from collections.abc import Sequence

import pandas as pd

from selfsense.envelope.render import combined_envelope
from selfsense.envelope.verdicts import NO_ENVELOPE

#: a row's key in every table
KEY = ["source", "quantity"]
#: the nominal scorecard's columns kept, as the review names them
NOMINAL = {
    "reproduced": "nominal",
    "band low": "band low",
    "band high": "band high",
    "verdict": "nominal verdict",
}
#: the envelope scorecard's columns kept, as the review names them
ENVELOPE = {"p2.5": "envelope p2.5", "p97.5": "envelope p97.5", "envelope verdict": "envelope"}
#: the validation's verdicts' columns kept, as the review names them
POSTERIOR = {
    "p2.5": "posterior p2.5",
    "p50": "posterior p50",
    "p97.5": "posterior p97.5",
    "implausibility": "implausibility",
    "verdict": "posterior",
    "fold": "fold",
    "twin of": "twin of",
    "driven by": "driven by",
}


def review_table(
    verdicts: pd.DataFrame, nominal: pd.DataFrame | None, envelopes: Sequence[pd.DataFrame]
) -> pd.DataFrame:
    """One row per row of ``verdicts`` (the validation's, in its order): chapter, source,
    quantity, unit, published; the nominal's value, band and verdict from ``nominal`` (its
    published rows); the envelope's interval and verdict from the design of ``envelopes`` that
    judges the row (:func:`selfsense.envelope.render.combined_envelope`: the first has every
    row); the posterior's interval, implausibility, verdict, fold, twin and drivers."""
    out = verdicts[["chapter", *KEY, "unit", "published"]].copy()
    out = out.join(verdicts[list(POSTERIOR)].rename(columns=POSTERIOR))
    if nominal is not None and len(nominal):
        rows = nominal[nominal["section"] == "published"] if "section" in nominal else nominal
        kept = rows[KEY + list(NOMINAL)].rename(columns=NOMINAL).drop_duplicates(KEY)
        out = out.merge(kept, on=KEY, how="left")
    else:
        out = out.assign(**{c: pd.NA for c in NOMINAL.values()})
    if envelopes:
        card = combined_envelope(envelopes)
        judged = card[card["envelope verdict"] != NO_ENVELOPE]
        out = out.merge(judged[KEY + list(ENVELOPE)].rename(columns=ENVELOPE), on=KEY, how="left")
    else:
        out = out.assign(**{c: pd.NA for c in ENVELOPE.values()})
    out["envelope"] = out["envelope"].fillna(NO_ENVELOPE)
    order = ["chapter", *KEY, "unit", "published", *NOMINAL.values(), *ENVELOPE.values()]
    return out[order + [c for c in POSTERIOR.values()]]
