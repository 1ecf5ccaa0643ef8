"""Everything that reads or writes files.

- ``capture``: the capture contract (netCDF4): write, open, validate, stream;
- ``contract``: the checks a capture must pass (attributes, agreement, clipping);
- ``manifest``: dataset manifests, protocols and config, validated against ``schemas/``;
- ``roles``: which part each run plays in the stages (the catalogue's, or a manifest's mapping);
- ``provenance``: atomic outputs with their provenance sidecars, script logging;
- ``audit``: outputs against their inputs by content (``selfsense audit``, the start-of-run
  check);
- ``importer``: a lab's recordings into captures and a manifest (``selfsense import``);
- ``sources``: what the import and its readers share (ImportProblem, Column, argument parsing);
- ``csv_source``: the import's CSV/TSV reader (separator detection, chunks);
- ``mat_source``: the import's MATLAB readers, v4–v7 (scipy) and v7.3 (h5py);
- ``tdms_source``: the import's NI TDMS reader (nptdms);
- ``dataset_lock``: one import into a dataset at a time (``raw/<dataset>/.import.lock``);
- ``config_docs``: docs/configuration.md, generated from the config schema.
"""
