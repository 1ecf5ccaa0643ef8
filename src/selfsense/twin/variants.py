"""The twin's variants: mechanisms of the bench that today's twin leaves out, each a switchable
term whose parameters (a manifest's ``twin.<variant>``, :data:`.params.VARIANTS`) are off by
default, so that a manifest without them makes today's captures bit for bit (docs/twin.md,
"Variants"). Each is a pure function, or a small per-sample stage in numba with its numpy
reference, which the tests hold it to and to the term's closed form.
"""

from __future__ import annotations


def series_load(k_load: float, compliance: float) -> float:
    """The stiffness a load k_load presents through a compliance c in series with it:
    1/(1/k_load + c). No load (0) or no compliance leaves k_load as it is, the same float."""
    if k_load == 0.0 or compliance == 0.0:
        return k_load
    return 1.0 / (1.0 / k_load + compliance)
