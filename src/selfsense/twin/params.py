"""Physical parameters of the bench's digital twin, read from a dataset manifest.

Every number here is a physical or instrument parameter (thesis Tables 2.1, 4.2, 5.3, 7.1 and
the instruments' data sheets); none is an analysis setting. Units are SI.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import MISSING, asdict, dataclass, field, fields
from typing import Any, get_type_hints

import numpy as np

from selfsense.methods.lti import BUTTERWORTH_Q


def _build(cls, values: Mapping[str, Any], where: str):
    names = {f.name for f in fields(cls)}
    unknown = sorted(set(values) - names)
    if unknown:
        raise ValueError(f"{where}: unknown key(s) {', '.join(unknown)}")
    return cls(**{k: (tuple(v) if isinstance(v, list) else v) for k, v in values.items()})


def build_sections(cls, twin: Mapping[str, Any], where: str):
    """A twin's parameters ``cls`` (a dataclass of sections) from a manifest's twin block: every
    section present but the variants (a section with a default: the term off) and none unknown,
    each built into the type its field is annotated with."""
    kinds = get_type_hints(cls)
    optional = {f.name for f in fields(cls) if f.default_factory is not MISSING}
    missing = sorted(set(kinds) - set(twin) - optional)
    unknown = sorted(set(twin) - set(kinds))
    if missing or unknown:
        raise ValueError(
            f"{where}: missing key(s) {', '.join(missing) or '-'}; "
            f"unknown key(s) {', '.join(unknown) or '-'}"
        )
    return cls(
        **{
            name: _build(kind, twin[name], f"{where}.{name}")
            for name, kind in kinds.items()
            if name in twin
        }
    )


@dataclass(frozen=True)
class StackParams:
    """Electromechanical model of the stack on its bench (Eq 4.2, Eq 4.4–4.6)."""

    k: float  # total stiffness k_P + k_spring [N/m]
    alpha: float  # force–voltage factor [N/V]
    C_P0: float  # clamped capacitance at U_P = 0 and T_ref [F]
    dC_x: float  # capacitance change with position ΔCx [F/m]
    kappa_T: float  # capacitance change with temperature [F/K]
    T_ref: float  # reference temperature of C_P0 [°C]
    f_bench: float  # bench natural frequency, sets the moving mass [Hz]
    zeta: float  # damping ratio of the bench mode
    k_spring: float = 0.0  # preload spring, part of k [N/m]

    @property
    def m(self) -> float:
        return self.k / (2 * np.pi * self.f_bench) ** 2

    @property
    def b(self) -> float:
        return 2 * self.zeta * np.sqrt(self.k * self.m)

    @property
    def dC_U(self) -> float:
        """ΔC_U = ΔCx·α/k (Eq 4.5)."""
        return self.dC_x * self.alpha / self.k


@dataclass(frozen=True)
class HysteresisParams:
    """Maxwell resistive-capacitive operator on charge (Eq 1.11–1.12).

    Element i has break-away voltage v_i = v_total/n and capacitance C_i = q_sat_i/v_i, with
    the saturation charges q_sat_i spaced geometrically so the loop rounds off smoothly.

    The operator is rate independent; its rate-dependent part is a viscous drop R_visc·I in series
    (the domain walls' friction grows with their speed, so the loop widens with the drive's rate:
    docs/twin.md, "Rate-dependent loss"). It is a Voigt element whose relaxation time tau_visc is
    far below the drive's periods (resistive up to Chapter 7's 200 Hz) and far above the ripple's
    (so the 100 kHz ripple does not see it) and the sample period (the kernel couples it
    explicitly).
    """

    elements: int
    v_total: float  # Σ v_i: half the height of a saturated U_H loop [V]
    q_sat_min: float  # [C]
    q_sat_max: float  # [C]
    R_visc: float = 0.0  # viscous resistance of the domain walls' motion [Ω]
    tau_visc: float = 2.0e-4  # its relaxation time [s]

    def arrays(self) -> tuple[np.ndarray, np.ndarray]:
        v = np.full(self.elements, self.v_total / self.elements)
        q_sat = np.geomspace(self.q_sat_min, self.q_sat_max, self.elements)
        return q_sat / v, v


@dataclass(frozen=True)
class CreepParams:
    """Slow relaxation (Voigt) elements in series with U_H; they make creep (Eq 1.13 idea)."""

    C: tuple[float, ...]  # [F]
    tau: tuple[float, ...]  # [s]


@dataclass(frozen=True)
class RippleParams:
    """Boost-converter ripple and the actuator's series R–C at the ripple frequency.

    The small-signal C_e and R_e depend on the domain state as well as on U_P (the reversible
    domain-wall contribution to the permittivity and to its loss, Rayleigh's law): through dC_H and
    dR_H they move with the voltage the hysteresis holds, U_H, so C_e–x and R_e–C_e show loops of
    their own while C_e follows x closely (:func:`.instruments.small_signal`).
    """

    amplitude: float  # ripple voltage amplitude [V]
    f_nominal: float  # [Hz]
    wander: float  # peak slow wander of the ripple frequency [Hz]
    wander_bandwidth: float  # how fast it wanders [Hz]
    phase_deg: float  # current lead at C_ref: sets R_e = 1/(ω C tan φ) at C_ref [deg]
    R_slope: float  # dR_e/dC_e: R_e falls as C_e rises (Fig 3.14) [Ω/F]
    C_ref: float  # [F]
    highpass_hz: float  # Sallen-Key cut-off on both ripple channels (18 kHz)
    highpass_q: float = BUTTERWORTH_Q  # the Sallen-Key's quality factor (Butterworth: 1/√2)
    dC_H: float = 0.0  # small-signal capacitance per volt of U_H [F/V]
    dR_H: float = 0.0  # small-signal resistance per volt of U_H [Ω/V]


@dataclass(frozen=True)
class ThermalParams:
    """Lumped thermal model ρcv dT/dt = U_H·I − k_T A (T − T_amb) (Eq 7.2–7.7)."""

    rho: float  # [kg/m³]
    c: float  # [J/(kg K)]
    volume: float  # [m³]
    area: float  # [m²]
    k_T: float  # [W/(m² K)]
    T_amb: float  # [°C]

    @property
    def tau(self) -> float:
        return self.rho * self.c * self.volume / (self.k_T * self.area)

    @property
    def gamma(self) -> float:
        return 1.0 / (self.k_T * self.area)


@dataclass(frozen=True)
class InstrumentParams:
    """Noise, offsets and ranges of the DAQ chain; ranges are the ADC full scale per channel.

    The current probe and the laser are specified by their resolution (Table 2.1): each records
    its input rounded to multiples of it (:func:`.instruments.resolve`), the rectangular error of
    half-width resolution/2 that the GUM assigns to a stated resolution (standard uncertainty
    resolution/√12), instead of a noise whose size the specification does not give.
    """

    U_noise: float  # [V rms]
    I_offset: float  # current-probe offset I_0 [A]
    I_offset_drift: float  # peak slow drift of I_0 [A]
    I_resolution: float  # current probe [A], Table 2.1
    ripple_noise_U: float  # [V rms]
    ripple_noise_I: float  # [A rms]
    laser_resolution: float  # laser vibrometer [m], Table 2.1
    laser_drift: float  # peak slow drift [m]
    F_noise: float  # [N rms]
    F_preload: float  # [N]
    T_noise: float  # [K rms]
    T_rate: float  # IR thermometer sample rate [Hz]
    T_gradient: tuple[float, float, float]  # share of the rise seen at top, mid, bottom
    ranges: Mapping[str, tuple[float, float]]
    I_offset_drift_bandwidth: float = 0.05  # how fast I_0 drifts [Hz]
    laser_drift_bandwidth: float = 0.005  # how fast the laser drifts [Hz]
    I_probe_gain_at_ripple: float = 1.0  # the probe's gain at the ripple frequency over its DC gain
    adc_bits: int = 16  # the ADC's resolution on the fast channels (stored as int16 codes)
    amplifier_gain_at_folded_ripple: float = 1.0  # first-order amplifier's gain at fs/ns; 1: ideal


@dataclass(frozen=True)
class LoadPathParams:
    """A compliance in series with a run's load (the static blocked-force test's force sensor):
    the frame, ball seats and mounts between stack and sensor. The stack pushes on
    1/(1/k_load + compliance) (:func:`.variants.series_load`); 0: the load alone (today's twin)."""

    compliance: float = 0.0  # [m/N]


@dataclass(frozen=True)
class PowerAmplifierParams:
    """The stack's PI E-617.00F from command to stack (:class:`.variants.PowerAmplifier`): a first
    order stage of time constant τ whose output slews at most 1/slew_time volts a second (its
    current limit I_max into the load C_load: slew_time = C_load/I_max), output −20…120 V (the
    E-617's −2…12 V input at gain 10). Both 0: the ideal amplifier (today's twin)."""

    time_constant: float = 0.0  # τ = 1/(2π f_c) of its small-signal bandwidth f_c [s]
    slew_time: float = 0.0  # C_load/I_max [s/V]

    @property
    def on(self) -> bool:
        return self.time_constant > 0 or self.slew_time > 0


@dataclass(frozen=True)
class LoopParams:
    """The DAQ's output latency (:class:`.variants.Delay`): a command reaches the amplifier
    delay_samples samples after the sample it was computed at; 0: at once (today's twin)."""

    delay_samples: int = 0


@dataclass(frozen=True)
class HysteresisRateParams:
    """Rate-dependent hysteresis: every Maxwell element's break-away voltage v_i times
    1 + width_per_current·|Ī|, Ī the stack's current up to the sample before, smoothed over
    :data:`.kernel.RATE_SMOOTHING` (the rate-dependent thresholds of a Prandtl–Ishlinskii
    operator: the loop widens with the drive's rate). 0: the rate-independent operator (today's
    twin)."""

    width_per_current: float = 0.0  # β [1/A]


@dataclass(frozen=True)
class DielectricParams:
    """A dielectric relaxation across the stack's terminals (Debye): a branch C_d in series with
    R_d = tau/C_d, driven by the terminal voltage, its admittance jωC_d/(1 + jωτ); its current
    adds to the stack's, its R_d·I_d² to the heat. C_d = 0: no branch (today's twin)."""

    C_d: float = 0.0  # [F]
    tau: float = 1.0e-3  # R_d·C_d [s]


@dataclass(frozen=True)
class SupportParams:
    """The support mode: the stack's base on a support of modal mass m_s held to the frame by a
    stiffness k_s = 1/compliance with damping b_s = 2·zeta·√(k_s·m_s), a two-mass bench
    (:func:`.kernel.kernel_constants`; docs/twin.md, "Variants"). The stack (k, b) acts between
    the moving mass and the support, its force α·U_P on the one and its reaction on the other;
    the laser reads the moving mass against the frame. compliance = 0: a rigid support (today's
    single-mode twin, whatever mass and zeta say)."""

    compliance: float = 0.0  # c_s = 1/k_s [m/N]
    mass: float = 1.0  # m_s [kg]
    zeta: float = 0.05  # ζ_s

    @property
    def on(self) -> bool:
        return self.compliance > 0

    @property
    def k(self) -> float:
        return 1.0 / self.compliance

    @property
    def b(self) -> float:
        return 2 * self.zeta * np.sqrt(self.k * self.mass)


#: the twin's variants: mechanisms a manifest may switch on, each off by default (docs/twin.md,
#: "Variants"); /truth records a variant's parameters only when it is on
VARIANTS = ("load_path", "power_amplifier", "loop", "hysteresis_rate", "dielectric", "support")


@dataclass(frozen=True)
class TwinParams:
    stack: StackParams
    hysteresis: HysteresisParams
    creep: CreepParams
    ripple: RippleParams
    thermal: ThermalParams
    instruments: InstrumentParams
    load_path: LoadPathParams = field(default_factory=LoadPathParams)
    power_amplifier: PowerAmplifierParams = field(default_factory=PowerAmplifierParams)
    loop: LoopParams = field(default_factory=LoopParams)
    hysteresis_rate: HysteresisRateParams = field(default_factory=HysteresisRateParams)
    dielectric: DielectricParams = field(default_factory=DielectricParams)
    support: SupportParams = field(default_factory=SupportParams)

    def __post_init__(self):
        if self.power_amplifier.on and self.instruments.amplifier_gain_at_folded_ripple < 1:
            raise ValueError(
                "twin: power_amplifier and instruments.amplifier_gain_at_folded_ripple below 1 "
                "are two models of one amplifier: set one"
            )

    @classmethod
    def from_manifest(cls, twin: Mapping[str, Any], where: str = "twin") -> TwinParams:
        if "instruments" in twin:  # the ADC ranges are pairs, nested below the section
            instruments = dict(twin["instruments"])
            instruments["ranges"] = {k: tuple(v) for k, v in instruments.get("ranges", {}).items()}
            twin = dict(twin) | {"instruments": instruments}
        return build_sections(cls, twin, where)

    def truth_attrs(self) -> dict[str, float]:
        """Flat {section_key: value} of every scalar parameter, for the capture's /truth group."""
        out: dict[str, float] = {}
        for part in fields(self):
            obj = getattr(self, part.name)
            if part.name in VARIANTS and (obj == type(obj)() or not getattr(obj, "on", True)):
                continue  # off: today's twin, whose /truth it leaves as it was
            for key, value in asdict(obj).items():
                if isinstance(value, (int, float)):
                    out[f"{part.name}_{key}"] = float(value)
                elif isinstance(value, tuple) and all(isinstance(v, (int, float)) for v in value):
                    out[f"{part.name}_{key}"] = np.asarray(value, dtype=float)
        s = self.stack
        out |= {
            "stack_m": s.m,
            "stack_b": s.b,
            "stack_dC_U": s.dC_U,
            "thermal_tau": self.thermal.tau,
            "thermal_gamma": self.thermal.gamma,
        }
        return out
