"""The reproduction envelope (docs/envelope.md): the twin across what the sources leave open.

- ``unknowns``: the declared unknowns of the twin and the protocols (workflow/unknowns.yaml),
  their loader and hash;
- ``design``: the envelope's design read from config, the unknowns it varies and holds, SALib's
  sampling plan and each member's manifest;
- ``verdicts``: every emergent number against its envelope over the members: percentiles,
  verdict, the Morris screening of its drivers, the summary;
- ``figures``: the envelope's forest and tornado figures;
- ``render``: the envelope's counts and inconsistent numbers as the documentation quotes them.
"""
