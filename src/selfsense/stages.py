"""The stage plan: which analysis stages run for a dataset and, for each skipped one, what the
dataset lacks of what it needs.

Pure: a manifest and its experiments in, the plan out. It is written once and used twice: the
workflow gates its rules with it (``workflow/rules/common.smk`` derives every ``*_DATASETS`` list
from :func:`plan_stages`) and rule ``stage_plan`` writes it as ``results/<dataset>/stages.csv``
(:meth:`StagePlan.rows`), so a dataset's table says exactly what its run does. A stage runs when
its dataset lacks nothing: neither what the stage needs itself (channels, the runs of its
:attr:`Stage.roles`, manifest keys) nor a stage it builds on (:attr:`Stage.after`).

Which run plays which part is the catalogue's (``roles:`` in ``workflow/protocols``) or the
manifest's (:func:`selfsense.io.roles.assign_roles`); the rules and the library read runs by
role (:func:`runs`, :func:`run`), so the roles a stage lists here are every run its rules read.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

from selfsense.io.capture import DISPLACEMENT
from selfsense.io.manifest import require_keys
from selfsense.io.roles import ROLES, Experiments, by_frequency, runs

#: the Chapter 3 series by drive frequency (Figures 3.9–3.14, hysteresis, C_e recovery): roles
CH3_SERIES = {"10 Hz": "ch3.series_10hz", "1 Hz": "ch3.series_1hz", "0.1 Hz": "ch3.series_0p1hz"}
#: the drive frequencies [Hz] of Table 5.4 (the open-loop observer error)
TABLE_5_4_HZ = (0.01, 0.1, 1.0, 10.0, 50.0, 100.0)
#: a0 is fitted on the sines from this drive frequency [Hz] up (Eq 5.3: 10–300 Hz)
CHARGE_SINES_FROM_HZ = 10
#: the profiles of Chapter 6 (Tables 6.1, 6.2 and P3): {profile: (open-loop role, closed-loop role)}
PROFILES = {
    p: (f"control.{p.lower()}_open", f"control.{p.lower()}_closed")
    for p in ("P1", "P2a", "P2b", "P2c", "P2d", "P3")
}
#: the Ronkanen open-loop comparison: {"<kind>_<control>": role}
RONKANEN_PAIRS = {
    f"{kind}_{control}": f"powerloss.{kind}_{control}"
    for kind in ("decay", "repeat", "drift")
    for control in ("current", "voltage")
}
#: Figs 3, 4, 5 (and 6): the ±300 nA ramps with too large, too small and ideal compensation
RONKANEN_VELOCITY_RAMPS = (
    "powerloss.ramp_too_large",
    "powerloss.ramp_too_small",
    "powerloss.ramp_ideal",
)


def charge_sines(experiments: Experiments) -> dict[float, str]:
    """{frequency [Hz]: experiment} of the 10–300 Hz sines a0 is fitted on (Eq 5.3)."""
    sines = by_frequency(experiments, "observer.sine")
    return {f: e for f, e in sines.items() if f is not None and f >= CHARGE_SINES_FROM_HZ}


def observed_sines(experiments: Experiments) -> dict[float, str]:
    """{frequency [Hz]: experiment} of the sines the observer is evaluated on (Table 5.4)."""
    sines = by_frequency(experiments, "observer.sine")
    return {f: e for f, e in sines.items() if f in TABLE_5_4_HZ}


def closed_loop(experiments: Experiments) -> list[str]:
    """The closed-loop experiments (of the ch6 catalogue)."""
    return [e for e, x in experiments.items() if x is not None and x.control == "closed_loop"]


def profile_runs(experiments: Experiments, profiles=tuple(PROFILES)) -> dict[str, str]:
    """{run: its profile} of the Chapter 6 runs of ``profiles`` the dataset has, open and closed."""
    return {e: p for p in profiles for role in PROFILES[p] for e in runs(experiments, role)}


def _channels(manifest: Mapping[str, Any], *channels: str) -> list[str]:
    recorded = set(manifest["daq"]["channels"])
    return [f"channel {c}" for c in channels if c not in recorded]


def _characterise(manifest, experiments):
    recorded = set(manifest["daq"]["channels"])
    displacement = (
        [] if recorded & set(DISPLACEMENT) else ["a displacement channel x_laser or x_disp"]
    )
    return _channels(manifest, "U") + displacement


def _ripple(manifest, experiments):
    plan = [] if "ripple" in manifest["daq"] else ["daq.ripple"]
    return _channels(manifest, "Ur", "Ir", "U", "I", "x_laser") + plan


def _none(manifest, experiments):
    """A stage whose needs are its roles and the stages it builds on: nothing more to lack."""
    return []


def _observer(manifest, experiments):
    if not runs(experiments, "observer.sine"):
        return []  # the role's own row says so
    observed = observed_sines(experiments)
    return ([] if charge_sines(experiments) else ["10–300 Hz runs of role observer.sine"]) + [
        f"the {f:g} Hz run of role observer.sine" for f in TABLE_5_4_HZ if f not in observed
    ]


def _thermal(manifest, experiments):
    return _channels(manifest, "T_mid")


def _powerloss(manifest, experiments):
    return _channels(manifest, "U", "I", "i_cmd", "x_disp")


@dataclass(frozen=True)
class Stage:
    """One analysis stage: a row of stages.csv."""

    #: how the workflow and the other stages name it (``after``, "the <key> stage")
    key: str
    #: the row's name in stages.csv
    title: str
    #: what it needs, in words (the row's needs column)
    needs: str
    #: what of its own needs beyond its roles a dataset lacks: (manifest, experiments) -> [lack]
    lacks: Callable[[Mapping[str, Any], Experiments], list[str]] = _none
    #: the roles (:data:`selfsense.io.roles.ROLES`) whose runs its rules read: each needs a run
    roles: tuple[str, ...] = ()
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
        "ripple stage and the Chapter 3 series at 10, 1 and 0.1 Hz",
        roles=tuple(CH3_SERIES.values()),
        after=("ripple",),
    ),
    Stage(
        "identify",
        "identify (Ch. 4)",
        "ripple stage, Chapter 4 sine sets and the static stiffness tests",
        roles=(
            "identify.set",
            "identify.static_free",
            "identify.static_blocked",
            "identify.force_record",
            "identify.recovery_drive",
        ),
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
        "ripple stage and the 0.1 Hz run Γ is fitted on",
        roles=("gamma.fit",),
        after=("ripple",),
    ),
    Stage(
        "observer",
        "observer (Ch. 5)",
        "gamma stage, the Table 5.4 sines, 10–300 Hz sines and the creep run",
        _observer,
        roles=("observer.sine", "observer.creep", "observer.study"),
        after=("gamma",),
    ),
    Stage(
        "frequency_response",
        "frequency response (Ch. 5, Fig 5.3)",
        "identify stage and the stepped-sine sweep",
        roles=("frequency_response.sweep",),
        after=("identify",),
    ),
    Stage(
        "control",
        "control (Ch. 6)",
        "observer and identify stages and the profiles P1–P3, open and closed loop",
        roles=tuple(role for pair in PROFILES.values() for role in pair),
        after=("observer", "identify"),
    ),
    Stage(
        "thermal",
        "thermal (Ch. 7)",
        "observer and identify stages, the Chapter 7 runs and T_mid",
        _thermal,
        roles=(
            "thermal.heating",
            "thermal.voltage",
            "thermal.check",
            "thermal.gamma_t_fit",
            "thermal.gamma_t_validation",
            "thermal.coupled_fig_7_10",
            "thermal.coupled_fig_7_11",
            "thermal.coupled_fig_7_12",
        ),
        after=("observer", "identify"),
        manifest_keys=("actuator.thermal",),
    ),
    Stage(
        "powerloss",
        "powerloss (Ronkanen)",
        "U, I, i_cmd, x_disp channels and the Ronkanen runs",
        _powerloss,
        roles=(
            "powerloss.hold",
            "powerloss.ramp",
            *RONKANEN_VELOCITY_RAMPS,
            *RONKANEN_PAIRS.values(),
        ),
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
        roles = [f"role {r} ({ROLES[r]})" for r in stage.roles if not runs(experiments, r)]
        own = roles + stage.lacks(manifest, experiments)
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
