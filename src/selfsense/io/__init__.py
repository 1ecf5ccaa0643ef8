"""Everything that reads or writes files.

- ``capture``: the capture contract (netCDF4): write, open, validate, stream;
- ``contract``: the checks a capture must pass (attributes, agreement, clipping);
- ``manifest``: dataset manifests, protocols and config, validated against ``schemas/``;
- ``provenance``: atomic outputs with their provenance sidecars, script logging;
- ``audit``: outputs against their inputs by content (``selfsense audit``, the start-of-run
  check);
- ``importer``: a lab's CSV/MAT recordings into captures (``selfsense import``);
- ``figures``: the plotting helpers every figure is drawn with;
- ``config_docs``: docs/configuration.md, generated from the config schema.
"""
