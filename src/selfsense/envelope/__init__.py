"""The envelope and the validation: what the twin's declared unknowns allow, and what the
thesis's measurements leave of them.

The validation's modules (docs/validation.md):

- ``validation``: the declaration workflow/validation.yaml (folds, common targets, observation
  and discrepancy spreads, cutoff, waves), loaded and checked;
- ``emulator``: per-output Gaussian-process emulators and their leave-one-out diagnostics;
- ``history_matching``: implausibility, the region not ruled out and the waves' designs;
- ``fold_prediction``: every fold predicted from the others, its verdicts and the
  fold-compatibility map;
- ``coverage``: the method's own test on pseudo-theses with known truth.
"""
