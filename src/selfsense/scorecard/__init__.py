"""The scorecard (docs/scorecard.md): every published number beside its reproduction.

- ``registry``: the published numbers, their bands and kinds (workflow/scorecard.yaml);
- ``scoring``: each entry's reproduced value, band and verdict, and the counts;
- ``render``: the report's pages and the documentation's quoted blocks;
- ``reference_values``: a measured dataset's own reference numbers as entries;
- ``card``: a dataset's whole scorecard (the registry's rows and its reference values') and
  the tables it reads;
- ``calibration``: the twin's calibration signatures judged the same way.
"""
