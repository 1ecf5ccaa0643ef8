"""The envelope and the validation: what the twin's declared unknowns allow (the reproduction
envelope, docs/envelope.md), and what the thesis's measurements leave of them (docs/validation.md).

The envelope's modules:

- ``unknowns``: the declared unknowns of the twin and the protocols (workflow/unknowns.yaml),
  their loader and hash;
- ``design``: the envelope's design read from config, the unknowns it varies and holds, SALib's
  sampling plan and each member's manifest;
- ``verdicts``: every emergent number against its envelope over the members: percentiles,
  verdict, the Morris screening of its drivers, the summary;
- ``figures``: the envelope's forest and tornado figures, and the validation's;
- ``render``: the envelope's and the validation's counts and inconsistent numbers as the
  documentation quotes them.

The validation's modules:

- ``validation``: the declaration workflow/validation.yaml (folds, common targets, observation
  and discrepancy spreads, cutoff, waves), loaded and checked;
- ``emulator``: per-output Gaussian-process emulators and their leave-one-out diagnostics;
- ``history_matching``: implausibility, the region not ruled out and the waves' designs;
- ``fold_prediction``: every fold predicted from the others, its verdicts and the
  fold-compatibility map;
- ``coverage``: the method's own test on pseudo-theses with known truth;
- ``campaign``: the declared waves as workflow members in resumable batches, and their tables;
- ``judgement``: the verdicts, the next wave's design, the coverage and each row's drivers from
  those tables alone;
- ``review``: the verdicts beside the nominal scorecard and the prior envelope, row by row;
- ``variant_choice``: the twin's variants as models of their own, each fold predicted from the
  others under each, what each reconciles and breaks.

Both run their members through ``member``: a member in one job, its rules' own jobs run by their
scripts in one process.
"""
