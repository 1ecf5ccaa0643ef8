"""The analysis methods of the sources, pure: arrays and dataclasses in and out.

- ``ripple``: the folded-sampling plan and C_e, R_e from the ripple (Ch. 3);
- ``electromech``: the electromechanical model's identification (Ch. 4);
- ``gamma``: the ANOVA regression of Γ (Ch. 5, Ch. 7);
- ``observer``, ``selfsensing``: the hybrid position observer and the self-sensing chain (Ch. 5);
- ``control``: the integral loop's gains and tracking (Ch. 6);
- ``thermal``: self-heating, its model and estimator (Ch. 7);
- ``powerloss``: Ronkanen's power-loss compensation;
- ``frequency_response``: the stepped-sine sweep against Eq 5.2;
- ``cycles``: a recording cut into its drive's cycles, steady and dropped;
- ``hysteresis``: an actuator's own Maxwell model identified on its steady cycles;
- ``drive``: an experiment's drive profile from its protocol;
- ``metrics``, ``lti``: loop measures and discrete-time filters shared by the above.
"""
