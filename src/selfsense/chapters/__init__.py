"""Per-chapter assembly: stage results in, the chapter's tables and figures out.

``ch3`` (the ripple measurement), ``ch4`` (the electromechanical model), ``ch5`` (Γ and the
observer), ``ch6`` (closed-loop control) and ``ch7`` (self-heating) for the thesis, ``ronkanen``
for the paper; ``figure_names`` names every figure file once, for the rules and the modules that
draw them.
"""
