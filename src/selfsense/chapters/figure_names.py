"""The file name of every figure the pipeline makes, written once: the chapter code that builds a
figure and the rule that declares it both take its name from here.

This module imports nothing, so the workflow reads it when it loads without paying for the
chapter modules' matplotlib, scipy and python-control (≈ 2 s of every `snakemake` start).
"""

#: Figures 3.3–3.14, in the order ``ch3.figures_ch3`` builds them
CH3 = (
    "fig_3_3",
    "fig_3_4",
    "fig_3_7",
    "fig_3_9",
    "fig_3_10",
    "fig_3_11",
    "fig_3_12",
    "fig_3_13",
    "fig_3_14",
)
#: ``ch3.figure_3_2`` (the ripple's velocity, a model)
CH3_MODEL = "fig_3_2"
#: Figures 4.2–4.8 of ``ch4.figures_ch4``
CH4 = ("fig_4_2", "fig_4_3", "fig_4_4", "fig_4_5", "fig_4_6", "fig_4_7", "fig_4_8")
#: ``ch5.figure_5_3`` (the stepped-sine sweep)
CH5_SWEEP = "fig_5_3"
#: the figures of ``ch5.figures_ch5``
CH5 = (
    "fig_5_1",
    "fig_5_2",
    "fig_5_4",
    "fig_5_5",
    "fig_5_6",
    "fig_5_7",
    "fig_5_8",
    "fig_5_10",
    "fig_5_12",
    "fig_5_13",
    "fig_5_14",
)
#: the observer study's figure (``ch5.observer_study``)
CH5_STUDY = "fig_5_observer_study"
#: the observer's error budget against the twin's truth (``figures.error_budget``)
CH5_BUDGET = "fig_5_error_budget"
#: Figures 6.2–6.8 of ``ch6.figures_ch6``
CH6 = ("fig_6_2", "fig_6_3", "fig_6_4", "fig_6_5", "fig_6_6", "fig_6_7", "fig_6_8")
#: the figures ``ch7.thermal_identification`` builds, and those of ``ch7.thermal_checks``, in order
CH7_THERMAL, CH7_CHECKS = ("fig_7_1", "fig_7_2"), ("fig_7_3", "fig_7_5", "fig_7_6")
#: ``ch7.figure_7_7``, ``ch7.figure_7_8`` and ``ch7.figure_7_9``
CH7_GAMMA_T, CH7_FREQUENCY, CH7_DIAGRAM = "fig_7_7", "fig_7_8", "fig_7_9"
#: ``ch7.figure_coupled``'s Figs 7.10–7.12 (each shows the run of role thermal.coupled_<name>;
#: the last, the mixed run, is the one the thesis reports the coupled errors for)
CH7_COUPLED = ("fig_7_10", "fig_7_11", "fig_7_12")
#: {figure of Ronkanen 2002: file name} of ``ronkanen.figures_paper``
RONKANEN = {n: f"fig_ronkanen_{n}" for n in range(2, 12)}

#: captures a page of a dataset's loop figure (``characterise.loop_page``) unless the config says
#: otherwise (``characterise.captures_per_job``)
LOOPS_PER_PAGE = 6


def loop_pages(experiments, per_page: int = LOOPS_PER_PAGE) -> dict[str, list[str]]:
    """The pages of a dataset's loop figure, figures/<dataset>/characterise/loops_<page>.png, in
    catalogue order: {page: its experiments}. Pages of one capture are named after it (a
    measured dataset grows by batches: a new capture never renames, nor moves a capture to,
    another page); pages of several are numbered ("01", "02", …), ``per_page`` a page."""
    names = list(experiments)
    if per_page == 1:
        return {name: [name] for name in names}
    return {
        f"{k // per_page + 1:02d}": names[k : k + per_page] for k in range(0, len(names), per_page)
    }
