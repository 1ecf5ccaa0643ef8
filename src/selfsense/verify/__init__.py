"""Verification against the twin's truth: what the analyses give back of what the twin was built
with. Everything here reads a simulated capture's ``/truth``; the analyses never do.

- ``truth``: the one reader and interpolation of ``/truth``;
- ``error_budget``, ``tracking_budget``, ``temperature_budget``: an error split into its sources;
- ``recovery``: identified parameters against the built ones and the model on truth;
- ``gamma_truth``, ``powerloss_truth``: Γ and the power-loss performance refitted on truth;
- ``loop_leak``: the closed loop's drive in the ripple channels;
- ``hysteresis_truth``: the twin's own rate-independent feedforward, for the Maxwell model fit;
- ``studies``: the ripple estimator's error against np and the ripple's wander;
- ``signatures``: the calibration signatures measured on short twin runs.
"""
