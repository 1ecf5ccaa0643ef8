"""Run roles: which part each run of a dataset plays in the stages.

A stage reads its runs by role, never by name: the catalogue (``workflow/protocols/*.yaml``)
declares the roles of each of its experiments (``roles: [identify.force_record]``), and a
manifest may map its own experiment names onto roles (``roles: {powerloss.hold: my_hold}``),
which then replaces the catalogue's runs of those roles. The stage plan
(:mod:`selfsense.stages`) lists the roles each stage needs and skips a stage whose roles have no
run, naming them; the rules and the library ask :func:`runs` and :func:`run` which runs play a
role, so a lab's dataset with its own names and a subset of the thesis's runs gets every stage
its runs allow.

A role is one run (``identify.force_record``: the 50 Hz set whose force Figure 4.2 shows) or a
set of runs in catalogue order (:data:`MANY`: ``identify.set``, every Chapter 4 sine set). A
one-run role declared on a catalogue entry of several sets is the first set's.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterable, Mapping
from typing import Any

#: {role: what it is}, every role a catalogue or a manifest may name (the stage plan's vocabulary)
ROLES = {
    "ch3.series_10hz": "the 10 Hz series of Figs 3.9–3.14",
    "ch3.series_1hz": "the 1 Hz series of Fig 3.13",
    "ch3.series_0p1hz": "the 0.1 Hz series of Fig 3.13",
    "identify.set": "the Chapter 4 sine sets, Eq 4.15–4.21",
    "identify.static_free": "the free-stroke static test, Eq 4.16",
    "identify.static_blocked": "the blocked-force static test, Eq 4.16",
    "identify.force_record": "the sine set whose force Fig 4.2 shows",
    "identify.recovery_drive": "the sine set the identified model is held to, Fig 4.8",
    "gamma.fit": "the 0.1 Hz sine Γ is fitted on, Tables 5.1–5.2",
    "observer.sine": "the Chapter 5 sines, Table 5.4 and a0's 10–300 Hz",
    "observer.creep": "the creep run of Chapter 5",
    "observer.study": "the sine the observer study replays, Fig 5.6",
    "frequency_response.sweep": "the stepped-sine sweep of Fig 5.3",
    "control.p1_open": "profile P1 in open loop, Table 6.1",
    "control.p1_closed": "profile P1 in closed loop, Table 6.1",
    "control.p2a_open": "profile P2a in open loop, Table 6.2",
    "control.p2a_closed": "profile P2a in closed loop, Table 6.2",
    "control.p2b_open": "profile P2b in open loop, Table 6.2",
    "control.p2b_closed": "profile P2b in closed loop, Table 6.2",
    "control.p2c_open": "profile P2c in open loop, Table 6.2",
    "control.p2c_closed": "profile P2c in closed loop, Table 6.2",
    "control.p2d_open": "profile P2d in open loop, Table 6.2",
    "control.p2d_closed": "profile P2d in closed loop, Table 6.2",
    "control.p3_open": "profile P3 in open loop",
    "control.p3_closed": "profile P3 in closed loop",
    "thermal.heating": "the constant-frequency heating runs, Table 7.1",
    "thermal.voltage": "the voltage-trend run, Table 7.1",
    "thermal.check": "the runs the thermal model's predictions are checked on, Figs 7.5–7.6",
    "thermal.gamma_t_fit": "the run Γ_T is fitted on, Tables 7.2–7.3",
    "thermal.gamma_t_validation": "the hotter run Γ_T's order is validated on",
    "thermal.coupled_fig_7_10": "the run of Fig 7.10's coupled estimation",
    "thermal.coupled_fig_7_11": "the run of Fig 7.11's coupled estimation",
    "thermal.coupled_fig_7_12": "the mixed run of Fig 7.12's coupled estimation",
    "powerloss.hold": "the static hold R is identified from, Fig 2",
    "powerloss.ramp": "the ramps with a trial impedance, Table 2",
    "powerloss.ramp_too_large": "the ramp with too large a compensation, Fig 3",
    "powerloss.ramp_too_small": "the ramp with too small a compensation, Fig 4",
    "powerloss.ramp_ideal": "the ramp with the ideal compensation, Figs 5–6",
    "powerloss.decay_current": "the decay test under current control, Figs 8–9",
    "powerloss.decay_voltage": "the decay test under voltage control, Figs 8–9",
    "powerloss.repeat_current": "the repeatability test under current control, Fig 10",
    "powerloss.repeat_voltage": "the repeatability test under voltage control, Fig 10",
    "powerloss.drift_current": "the 2 min drift test under current control, Fig 11",
    "powerloss.drift_voltage": "the 2 min drift test under voltage control, Fig 11",
}
#: the roles a set of runs plays, in catalogue order; every other role is one run's
MANY = frozenset(
    {"identify.set", "observer.sine", "thermal.heating", "thermal.check", "powerloss.ramp"}
)

#: a dataset's experiments: {name: its catalogue entry (an ``Experiment``), or None for a
#: measured capture the catalogue does not describe}
Experiments = Mapping[str, Any]


def _known(role: Any, where: str) -> str:
    if role not in ROLES:
        raise ValueError(f"{where}: {role!r} is no role (the roles: {', '.join(ROLES)})")
    return role


def catalogue_roles(declared: Iterable[str], first: bool, where: str) -> frozenset[str]:
    """The roles of one run of a catalogue entry that declares ``declared``: a one-run role is
    its first set's (``first``), a set's role every set's. ``where`` names the entry."""
    return frozenset(
        _known(r, f"{where}: key roles") for r in declared if r in MANY or first or r not in ROLES
    )


def runs(experiments: Experiments, role: str) -> list[str]:
    """The runs that play ``role``, in catalogue order (none: the dataset has no such run)."""
    return [e for e, x in experiments.items() if x is not None and role in x.roles]


def run(experiments: Experiments, role: str) -> str:
    """The one run that plays ``role`` (a stage that reads it runs only when it has one)."""
    found = runs(experiments, role)
    if len(found) != 1:
        raise ValueError(f"{len(found)} runs play role {role} (one does): {', '.join(found)}")
    return found[0]


def by_frequency(experiments: Experiments, role: str) -> dict[float | None, str]:
    """{nominal drive frequency [Hz]: run} of the runs that play ``role``, in catalogue order."""
    return {experiments[e].nominal_hz: e for e in runs(experiments, role)}


def _mapped(value: Any, where: str) -> dict[str, str | None]:
    """A manifest's runs for one role: {run: the catalogue run it follows, or None}."""
    if isinstance(value, str):
        return {value: None}
    if isinstance(value, list):
        return dict.fromkeys(value)
    return dict(value)


def assign_roles(
    experiments: Experiments,
    catalogue: Experiments,
    mapping: Mapping[str, Any],
    source: str,
) -> dict[str, Any]:
    """``experiments`` with the roles a manifest maps onto its runs (``roles:`` {role: run, a list
    of runs, or {run: the catalogue run it follows}}): each mapped role leaves the catalogue's
    runs and goes to the manifest's. A run the catalogue does not describe follows the catalogue
    run given for it, or the catalogue's one run of that role (its protocol: durations, drive,
    nominal frequency). One line naming ``source`` and the key for a role that is none, a run not
    among the dataset's, several runs for a one-run role, or a run whose protocol is unknown."""
    out = dict(experiments)
    for role, value in mapping.items():
        key = f"{source}: key roles.{role}"
        _known(role, key)
        wanted = _mapped(value, key)
        if role not in MANY and len(wanted) != 1:
            raise ValueError(f"{key}: one run plays this role, {len(wanted)} are given")
        for name, entry in out.items():
            if entry is not None and role in entry.roles:
                out[name] = dataclasses.replace(entry, roles=entry.roles - {role})
        for name, follows in wanted.items():
            if name not in out:
                raise ValueError(f"{key}: {name!r} is not among the dataset's experiments")
            entry = out[name]
            if entry is None or follows is not None:
                followed = _followed(catalogue, role, follows, f"{key}.{name}")
                entry = dataclasses.replace(followed, name=name, roles=frozenset())
            out[name] = dataclasses.replace(entry, roles=entry.roles | {role})
    return out


def _followed(catalogue: Experiments, role: str, follows: str | None, key: str) -> Any:
    """The catalogue entry a manifest's own run follows."""
    if follows is not None:
        if follows not in catalogue:
            raise ValueError(f"{key}: {follows!r} is no run of the dataset's protocols")
        return catalogue[follows]
    candidates = runs(catalogue, role)
    if len(candidates) != 1:
        raise ValueError(
            f"{key}: the catalogue has {len(candidates)} runs of this role; name the one it "
            f"follows ({{run: catalogue run}}, one of {', '.join(candidates) or 'none'})"
        )
    return catalogue[candidates[0]]
