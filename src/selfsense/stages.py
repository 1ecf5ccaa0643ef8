"""The stage plan: which analysis stages run for a dataset and, for each skipped one, what the
dataset lacks of what it needs.

Pure: a manifest and its experiments in, the plan out. It is written once and used twice: the
workflow gates its rules with it (``workflow/rules/common.smk`` derives every ``*_DATASETS`` list
from :func:`plan_stages`) and rule ``stage_plan`` writes it as ``results/<dataset>/stages.csv``
(:meth:`StagePlan.rows`), so a dataset's table says exactly what its run does. A stage runs when
its dataset lacks nothing: neither what the stage needs itself (channels, runs, manifest keys)
nor a stage it builds on (:attr:`Stage.after`).

The experiment names here are the catalogue's (``workflow/protocols``) and the thesis's: which
runs a chapter's tables are computed from is a fact of the experiments, not a setting.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

from selfsense.chapters.figure_names import CH7_COUPLED as _CH7_COUPLED_FIGURES
from selfsense.io.capture import DISPLACEMENT
from selfsense.io.manifest import require_keys

#: a dataset's experiments: {name: its catalogue entry (an ``Experiment``), or None for a measured
#: capture the catalogue does not describe}
Experiments = Mapping[str, Any]

#: the Chapter 3 runs by drive frequency (Figures 3.9–3.14, hysteresis, C_e recovery)
CH3_SERIES = {"10 Hz": "ch3_sine_10hz", "1 Hz": "ch3_sine_1hz", "0.1 Hz": "ch3_sine_0p1hz"}
#: the static stiffness tests of Eq 4.16
CH4_STATIC = ("ch4_static_free", "ch4_static_blocked")
#: Γ is fitted on the 0.1 Hz run (Tables 5.1, 5.2)
GAMMA_RUN = "ch5_sine_0p1hz"
#: the drive frequencies [Hz] of Table 5.4 (the open-loop observer error)
TABLE_5_4_HZ = (0.01, 0.1, 1.0, 10.0, 50.0, 100.0)
#: a0 is fitted on the sines from this drive frequency [Hz] up (Eq 5.3: 10–300 Hz)
CHARGE_SINES_FROM_HZ = 10
#: the creep run of Chapter 5 and the stepped-sine sweep of Fig 5.3
CREEP_RUN, SWEEP_RUN = "ch5_creep", "ch5_sweep"
#: the voltage-trend run of Table 7.1
CH7_VOLTAGE_RUN = "ch7_volt_150hz"
#: the runs the thermal model's predictions are checked on (Figures 7.5, 7.6)
CH7_CHECKS = ("ch7_heat_cool", "ch7_mixed_voltage")
#: the runs the coupled observer/thermal estimation is evaluated on (Figures 7.10–7.12)
CH7_COUPLED = tuple(_CH7_COUPLED_FIGURES.values())
#: Γ_T is fitted on the 50 Hz run (Tables 7.2, 7.3) and its order validated on the hotter 100 Hz run
GAMMA_T_RUNS = {"fit": "ch7_freq_50hz", "validation": "ch7_freq_100hz"}


def experiment_frequency(name: str) -> float | None:
    """Drive frequency [Hz] from a catalogue name such as ch5_sine_0p1hz (None without one)."""
    token = next((t for t in name.split("_") if t.endswith("hz")), None)
    return float(token[:-2].replace("p", ".")) if token else None


def sines(experiments: Experiments, prefix: str) -> dict[float | None, str]:
    """{frequency [Hz]: experiment} of the experiments named <prefix><f>hz, in catalogue order."""
    return {experiment_frequency(e): e for e in experiments if e.startswith(prefix)}


def ch4_sets(experiments: Experiments) -> list[str]:
    """The Chapter 4 sine sets (ch4_sine_*), in catalogue order."""
    return [e for e in experiments if e.startswith("ch4_sine_")]


def charge_sines(experiments: Experiments) -> dict[float, str]:
    """{frequency [Hz]: experiment} of the 10–300 Hz sines a0 is fitted on (Eq 5.3)."""
    return {f: e for f, e in sines(experiments, "ch5_sine_").items() if f >= CHARGE_SINES_FROM_HZ}


def observed_sines(experiments: Experiments) -> dict[float, str]:
    """{frequency [Hz]: experiment} of the sines the observer is evaluated on (Table 5.4)."""
    return {f: e for f, e in sines(experiments, "ch5_sine_").items() if f in TABLE_5_4_HZ}


def closed_loop(experiments: Experiments) -> list[str]:
    """The closed-loop experiments (of the ch6 catalogue)."""
    return [e for e, x in experiments.items() if x is not None and x.control == "closed_loop"]


def _channels(manifest: Mapping[str, Any], *channels: str) -> list[str]:
    recorded = set(manifest["daq"]["channels"])
    return [f"channel {c}" for c in channels if c not in recorded]


def _runs(experiments: Experiments, *runs: str) -> list[str]:
    return [f"run {r}" for r in runs if r not in experiments]


def _characterise(manifest, experiments):
    recorded = set(manifest["daq"]["channels"])
    displacement = (
        [] if recorded & set(DISPLACEMENT) else ["a displacement channel x_laser or x_disp"]
    )
    return _channels(manifest, "U") + displacement


def _ripple(manifest, experiments):
    plan = [] if "ripple" in manifest["daq"] else ["daq.ripple"]
    return _channels(manifest, "Ur", "Ir", "U", "I", "x_laser") + plan


def _ch3(manifest, experiments):
    return _runs(experiments, *CH3_SERIES.values())


def _identify(manifest, experiments):
    sets = [] if ch4_sets(experiments) else ["runs ch4_sine_*"]
    return sets + _runs(experiments, *CH4_STATIC)


def _gamma(manifest, experiments):
    return _runs(experiments, GAMMA_RUN)


def _observer(manifest, experiments):
    observed = observed_sines(experiments)
    return (
        ([] if charge_sines(experiments) else ["10–300 Hz runs ch5_sine_*"])
        + _runs(experiments, CREEP_RUN)
        + [f"the {f:g} Hz run ch5_sine_*" for f in TABLE_5_4_HZ if f not in observed]
    )


def _frequency_response(manifest, experiments):
    return (
        []
        if experiments.get(SWEEP_RUN) is not None
        else [f"run {SWEEP_RUN} (of the ch5 catalogue)"]
    )


def _control(manifest, experiments):
    return [] if closed_loop(experiments) else ["closed-loop runs (of the ch6 catalogue)"]


def _thermal(manifest, experiments):
    freq = [] if sines(experiments, "ch7_freq_") else ["runs ch7_freq_*"]
    runs = (CH7_VOLTAGE_RUN, *CH7_CHECKS, *CH7_COUPLED, *GAMMA_T_RUNS.values())
    return freq + _runs(experiments, *runs) + _channels(manifest, "T_mid")


def _powerloss(manifest, experiments):
    catalogue = [] if "ronkanen" in manifest["protocols"] else ["protocols: ronkanen"]
    return _channels(manifest, "U", "I", "i_cmd", "x_disp") + catalogue


@dataclass(frozen=True)
class Stage:
    """One analysis stage: a row of stages.csv."""

    #: how the workflow and the other stages name it (``after``, "the <key> stage")
    key: str
    #: the row's name in stages.csv
    title: str
    #: what it needs, in words (the row's needs column)
    needs: str
    #: what of its own needs a dataset lacks: (manifest, experiments) -> [lack, ...]
    lacks: Callable[[Mapping[str, Any], Experiments], list[str]]
    #: the stages it builds on: a dataset that skips one of them skips this one too
    after: tuple[str, ...] = ()
    #: manifest keys (dotted) it computes with that the dataset schema leaves optional
    manifest_keys: tuple[str, ...] = ()


#: every stage, in the order of stages.csv (a stage after those it builds on)
STAGES = (
    Stage(
        "characterise",
        "characterise",
        "channel U and a displacement x_laser or x_disp",
        _characterise,
    ),
    Stage(
        "ripple",
        "ripple (Ch. 3)",
        "ripple channels Ur, Ir with U, I, x_laser and a folding plan (daq.ripple)",
        _ripple,
    ),
    Stage(
        "ch3",
        "hysteresis and figures (Ch. 3)",
        "ripple stage and the Chapter 3 runs ch3_sine_10hz, ch3_sine_1hz, ch3_sine_0p1hz",
        _ch3,
        after=("ripple",),
    ),
    Stage(
        "identify",
        "identify (Ch. 4)",
        "ripple stage, Chapter 4 sine sets and the static stiffness tests",
        _identify,
        after=("ripple",),
        manifest_keys=(
            "actuator.moving_mass_kg",
            "actuator.dimensions_mm",
            "actuator.active_volume_mm3",
            "actuator.layer_thickness_um",
        ),
    ),
    Stage(
        "gamma",
        "gamma (Ch. 5)",
        "ripple stage and the 0.1 Hz run ch5_sine_0p1hz",
        _gamma,
        after=("ripple",),
    ),
    Stage(
        "observer",
        "observer (Ch. 5)",
        "gamma stage, the Table 5.4 sines, 10–300 Hz sines and ch5_creep",
        _observer,
        after=("gamma",),
    ),
    Stage(
        "frequency_response",
        "frequency response (Ch. 5, Fig 5.3)",
        "identify stage and the stepped-sine sweep ch5_sweep",
        _frequency_response,
        after=("identify",),
    ),
    Stage(
        "control",
        "control (Ch. 6)",
        "observer and identify stages and closed-loop runs",
        _control,
        after=("observer", "identify"),
    ),
    Stage(
        "thermal",
        "thermal (Ch. 7)",
        "observer and identify stages, the Chapter 7 runs and T_mid",
        _thermal,
        after=("observer", "identify"),
        manifest_keys=("actuator.thermal",),
    ),
    Stage(
        "powerloss",
        "powerloss (Ronkanen)",
        "U, I, i_cmd, x_disp channels and the ronkanen catalogue",
        _powerloss,
    ),
)

STAGE_KEYS = tuple(s.key for s in STAGES)


@dataclass(frozen=True)
class StagePlan:
    """One dataset's plan: per stage (in :data:`STAGES`' order), what the dataset lacks of it."""

    #: {stage key: what the dataset lacks for it}; empty: the stage runs
    lacks: Mapping[str, tuple[str, ...]]

    def runs(self, key: str) -> bool:
        """Whether the stage ``key`` runs for this dataset."""
        return not self.lacks[key]

    def running(self) -> list[str]:
        """The keys of the stages that run, in :data:`STAGES`' order."""
        return [s.key for s in STAGES if self.runs(s.key)]

    def rows(self) -> list[dict[str, Any]]:
        """The rows of stages.csv: {"stage", "runs", "needs"}; a skipped stage's needs name what
        this dataset lacks."""
        return [
            {
                "stage": s.title,
                "runs": self.runs(s.key),
                "needs": s.needs
                if self.runs(s.key)
                else f"{s.needs}; this dataset lacks: {', '.join(self.lacks[s.key])}",
            }
            for s in STAGES
        ]


def plan_stages(manifest: Mapping[str, Any], experiments: Experiments) -> StagePlan:
    """Which stages run for the dataset of ``manifest`` with ``experiments``, and what it lacks
    for each one skipped: the stages it builds on first, then its own needs. A manifest with a
    ``stages:`` list (an envelope member's) runs only those."""
    lacks: dict[str, tuple[str, ...]] = {}
    chosen = manifest.get("stages")
    for stage in STAGES:
        before = [f"the {key} stage" for key in stage.after if lacks[key]]
        own = stage.lacks(manifest, experiments)
        if chosen is not None and stage.key not in chosen:
            own = ["a place in the manifest's stages: list", *own]
        lacks[stage.key] = tuple(dict.fromkeys(before + own))
    return StagePlan(lacks)


def captures_made(
    manifest: Mapping[str, Any], experiments: Experiments, plan: StagePlan
) -> list[str]:
    """The experiments whose captures the dataset has or the workflow can make, in catalogue
    order: what the captures' table and the characterise stage read. A measured dataset's
    captures are given; the twin simulates a closed-loop run with the identified model and
    observer, the control stage's needs, so a simulated dataset has its closed-loop runs only
    when the control stage runs (reading them otherwise would run the skipped stages)."""
    if manifest["source"] != "simulated" or plan.runs("control"):
        return list(experiments)
    loops = set(closed_loop(experiments))
    return [e for e in experiments if e not in loops]


def check_manifest_keys(manifest: Mapping[str, Any], plan: StagePlan, source: Any) -> None:
    """The optional manifest keys each running stage computes with: the first one absent stops
    with one line naming the file, the key and the stage, before any job runs."""
    for stage in STAGES:
        if plan.runs(stage.key) and stage.manifest_keys:
            require_keys(manifest, stage.manifest_keys, source, f"the {stage.title} stage")
