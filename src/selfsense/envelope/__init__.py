"""The envelope and the validation: what the twin's declared unknowns allow, and what the
thesis's measurements leave of them.

The validation's modules (docs/validation.md):

- :mod:`selfsense.envelope.validation`: the declaration workflow/validation.yaml (folds, common
  targets, observation and discrepancy spreads, cutoff, waves), loaded and checked.
- :mod:`selfsense.envelope.emulator`: per-output Gaussian-process emulators and their
  leave-one-out diagnostics.
- :mod:`selfsense.envelope.history_matching`: implausibility, the not-ruled-out region and the
  waves' designs.
- :mod:`selfsense.envelope.fold_prediction`: every fold predicted from the others, its verdicts
  and the fold-compatibility map.
- :mod:`selfsense.envelope.coverage`: the method's own test on pseudo-theses with known truth.
"""
