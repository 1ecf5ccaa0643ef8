"""Per-chapter and per-stage assembly: stage results in, the tables and figures out.

``ch3`` (the ripple measurement), ``ch4`` (the electromechanical model), ``ch5`` (Γ and the
observer), ``ch6`` (closed-loop control) and ``ch7`` (self-heating) for the thesis, ``ronkanen``
for the paper; ``characterise`` for the characterise stage (any U–x recording opened, measured on
its steady cycles, its table row and loop pages); ``figures``, the plotting helpers every figure
is drawn with (arrays in, a matplotlib Figure out; it writes no file); ``figure_names`` names
every figure file once, for the rules and the modules that draw them.
"""
