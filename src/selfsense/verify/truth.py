"""The twin's noiseless states of a simulated capture (its ``/truth`` group), read one way and
interpolated one way for every verification against them."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

#: the /truth states the observer's error budget reads (the default of :class:`Truth`)
TRUTH_STATES = ("x", "q", "C_e", "I_offset")


@dataclass(frozen=True, eq=False)
class Truth:
    """The twin's noiseless states of one capture, stored every ``decimation``-th sample.

    ``source`` names the capture in error messages; ``n_samples`` is the capture's length, which the
    states must cover; ``names`` are the states a budget reads (the observer's by default).
    """

    states: Mapping[str, np.ndarray]
    decimation: int
    n_samples: int
    source: str = "capture"
    names: tuple[str, ...] = TRUTH_STATES
    _values: np.ndarray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        missing = [s for s in self.names if s not in self.states]
        if missing:
            raise ValueError(f"{self.source}: /truth lacks the state(s) {', '.join(missing)}")
        if int(self.decimation) < 1:
            raise ValueError(
                f"{self.source}: /truth decimation must be >= 1, got {self.decimation!r}"
            )
        values = np.array([np.asarray(self.states[s], dtype=np.float64) for s in self.names])
        needed = -(-int(self.n_samples) // int(self.decimation))
        if values.shape[1] < needed:
            raise ValueError(
                f"{self.source}: /truth has {values.shape[1]} values, the capture's "
                f"{self.n_samples} samples at decimation {self.decimation} need {needed}"
            )
        if not np.isfinite(values[:, :needed]).all():
            raise ValueError(f"{self.source}: /truth has non-finite values")
        object.__setattr__(self, "_values", values)

    @classmethod
    def from_group(
        cls,
        attrs: Mapping[str, object],
        states: Mapping[str, np.ndarray],
        n_samples: int,
        source: str = "capture",
        names: tuple[str, ...] = TRUTH_STATES,
    ) -> Truth:
        """From :meth:`selfsense.io.capture.Capture.read_truth`'s (attributes, states)."""
        if "decimation" not in attrs:
            raise ValueError(f"{source}: /truth has no decimation attribute")
        return cls(states, int(attrs["decimation"]), int(n_samples), source, tuple(names))

    @classmethod
    def from_capture(cls, capture, names: tuple[str, ...] = TRUTH_STATES) -> Truth:
        """The states ``names`` of an open simulated :class:`selfsense.io.capture.Capture` over its
        length (the rest of its /truth is not kept)."""
        attrs, states = capture.read_truth()
        return cls.from_group(
            attrs,
            {k: states[k] for k in names if k in states},
            capture.length(),
            str(capture.path),
            names,
        )

    def at(self, index: np.ndarray) -> dict[str, np.ndarray]:
        """Each state at the global sample indices ``index``.

        A 4-point cubic through the stored values: linear interpolation would be off by
        (ωΔ)²/8 of the amplitude, 50 nm on the 100 Hz sine at 4 kHz, near the laser's own 87 nm rms;
        the cubic's (ωΔ)⁴/43 is below 1 nm. Ends use the nearest values.
        """
        u = np.asarray(index, dtype=np.float64) / self.decimation
        i = np.floor(u).astype(np.int64)
        s = u - i
        weights = (
            (-s * (s - 1) * (s - 2) / 6),
            ((s + 1) * (s - 1) * (s - 2) / 2),
            (-(s + 1) * s * (s - 2) / 2),
            ((s + 1) * s * (s - 1) / 6),
        )
        last = self._values.shape[1] - 1
        out = sum(
            w * self._values[:, np.clip(i + k, 0, last)] for k, w in zip((-1, 0, 1, 2), weights)
        )
        return dict(zip(self.names, out))

    def means(self, last: np.ndarray, n: int, block: int = 1 << 14) -> dict[str, np.ndarray]:
        """Each state's mean over the ``n`` samples ending at each global index of ``last`` (the
        windows a series of means was taken over), ``block`` windows at a time to bound the
        memory."""
        offsets = np.arange(1 - n, 1)
        parts = []
        for start in range(0, len(last), block):
            ends = np.asarray(last[start : start + block])
            values = self.at((ends[:, None] + offsets).ravel())
            parts.append({k: v.reshape(len(ends), n).mean(axis=1) for k, v in values.items()})
        return {
            k: np.concatenate([p[k] for p in parts]) if parts else np.empty(0) for k in self.names
        }
