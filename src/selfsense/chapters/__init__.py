"""Per-chapter assembly: stage results in, the chapter's tables and figures out.

``ch3`` … ``ch7`` for the thesis, ``ronkanen`` for the paper; ``figure_names`` names every figure
file once, for the rules and the modules that draw them.
"""
