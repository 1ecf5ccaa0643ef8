"""The digital twin of the test bench (docs/design.md, "The digital twin"): the simulator only.

- ``experiment``: :func:`~selfsense.twin.experiment.simulate_experiment`, the entry point the
  workflow uses (a manifest and a catalogue experiment in, a capture out);
- ``params``: the twin's parameters from a manifest;
- ``bench``: the stack's bench, sample by sample (``kernel``, ``record``, ``instruments``,
  ``maxwell`` its physics, ``realtime`` its compiled closed loop, ``variants`` its switchable
  terms, off by default);
- ``closed_loop``: the bench's real-time self-sensing loop (Chapter 6);
- ``bender``: Ronkanen's bender and its current amplifier.

It uses :mod:`selfsense.io` and :mod:`selfsense.methods` only; nothing here is imported on import.
"""
