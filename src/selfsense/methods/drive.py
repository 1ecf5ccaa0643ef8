"""Drive profiles of the experiment catalogue (workflow/protocols/*.yaml), as functions of time.

A profile is a list of segments; each is evaluated from absolute time so that a capture can be
generated chunk by chunk with identical results. Voltage segments give the amplifier output U;
position segments give a reference x_R that open-loop runs turn into U = x_R·k/α (Chapter 6).
"""

from __future__ import annotations

import bisect
from collections.abc import Mapping
from dataclasses import dataclass
from functools import cached_property
from typing import Any

import numpy as np


@dataclass(frozen=True)
class Segment:
    """One stretch of drive: raised-cosine sine between lo and hi, or a hold at hi (frequency 0).

    value(t) = lo + (hi − lo)·(1 − cos 2πf(t − t0))/2, plus an optional sum of cosine terms
    (amplitude, frequency) for the multi-sine position profiles (P2c, P2d).
    """

    duration: float
    frequency: float = 0.0
    lo: float = 0.0
    hi: float = 0.0
    terms: tuple[tuple[float, float], ...] = ()

    def value(self, tau: np.ndarray) -> np.ndarray:
        if self.frequency > 0:
            out = self.lo + (self.hi - self.lo) * 0.5 * (
                1 - np.cos(2 * np.pi * self.frequency * tau)
            )
        else:
            out = np.full_like(tau, self.hi)
        for amplitude, freq in self.terms:
            out = out - amplitude * np.cos(2 * np.pi * freq * tau)
        return out


@dataclass(frozen=True)
class Drive:
    """A whole experiment's drive: segments in sequence, in volts or in metres of x_R."""

    quantity: str  # "voltage" or "position"
    segments: tuple[Segment, ...]

    @property
    def duration(self) -> float:
        return float(sum(s.duration for s in self.segments))

    @cached_property
    def starts(self) -> tuple[float, ...]:
        """Each segment's start time [s], and the end of the last."""
        starts = [0.0]
        for seg in self.segments:
            starts.append(starts[-1] + seg.duration)
        return tuple(starts)

    def __call__(self, t: np.ndarray) -> np.ndarray:
        out = np.zeros_like(t, dtype=float)
        start = self.starts[-1]
        if len(t):
            # only the segments t touches: the closed loop asks for 12 samples at a time
            first = max(0, bisect.bisect_right(self.starts, float(np.min(t))) - 1)
            last = bisect.bisect_right(self.starts, float(np.max(t)))
            for seg, begin in zip(self.segments[first:last], self.starts[first:last]):
                sel = (t >= begin) & (t < begin + seg.duration)
                out[sel] = seg.value(t[sel] - begin)
        if self.segments:
            last = self.segments[-1]
            sel = t >= start
            out[sel] = last.value(np.full(np.count_nonzero(sel), last.duration))
        return out


def drive_from_protocol(protocol: Mapping[str, Any], scale: float = 1.0) -> Drive:
    """Build a drive from a protocol entry. Position profiles are written in µm in the YAML.

    ``warmup`` [s] prepends a hold at zero: the bench sat idle while the real-time observer
    learned the current offset before a run started.
    """
    quantity = protocol.get("quantity", "voltage")
    unit = 1e-6 if quantity == "position" else 1.0
    warmup = float(protocol.get("warmup", 0.0)) * scale
    segments = [Segment(duration=warmup)] if warmup > 0 else []
    for seg in list(protocol["segments"]) * int(protocol.get("repeat", 1)):
        segments.append(
            Segment(
                duration=float(seg["duration"]) * scale,
                frequency=float(seg.get("frequency", 0.0)),
                lo=float(seg.get("lo", 0.0)) * unit,
                hi=float(seg.get("hi", 0.0)) * unit,
                terms=tuple((float(a) * unit, float(f)) for a, f in seg.get("terms", ())),
            )
        )
    return Drive(quantity, tuple(segments))
