"""Make the lab recordings of docs/bring-your-own-data.md's second and third worked examples with
the twin's stack (raw/pi_p885's parameters), as a lab's DAQ would have logged them:

- ``micromanipulator.tsv``: tab-separated, no header, no time column, 200 Hz; five channels of
  which column 2 is the amplifier's 1:20 monitor of the drive and column 5 a displacement sensor
  logged in volts at 10 µm/V that settles over its first 0.2 s (it starts 4 µm low), columns 1
  and 4 status lines that hold one value; the drive pauses, ramps up over three cycles, runs
  eight full cycles, pauses, ramps down and runs four more.
- ``sine_daq.tdms``: an NI TDMS file (group ``Bench``, channels ``Drive`` [V] and ``Position``
  [µm], 500 Hz given by the channels' ``wf_increment``), ten cycles of a 1 Hz sine.
- ``lab_examples_truth.json``: what the steady full-amplitude cycles give on the twin's noiseless
  position: stroke [µm] and loop width [% of stroke], the answers the examples are tested against.

Run from the repository's folder: ``.venv/bin/python tests/data/make_lab_examples.py``.
"""

import json
from pathlib import Path

import numpy as np

from selfsense.io.manifest import load_dataset
from selfsense.methods.metrics import branch_gap, direction
from selfsense.twin import kernel as K
from selfsense.twin.params import TwinParams

HERE = Path(__file__).parent
SIM_FS = 20000.0  # the twin's rate; the DAQ keeps every SIM_FS/fs-th sample
PERIOD = 1.0  # [s]
FULL = 100.0  # [V] a full cycle's peak drive


def twin_position(u: np.ndarray) -> np.ndarray:
    params = TwinParams.from_manifest(load_dataset(HERE.parents[1] / "raw", "pi_p885")["twin"])
    kc = K.kernel_constants(params, SIM_FS)
    T = params.thermal.T_amb
    out = K.run(u, np.zeros_like(u), np.full_like(u, T), kc, K.initial_state(kc, T))
    return out[:, K.OUTPUTS.index("x")]


def drive(peaks: list[float]) -> tuple[np.ndarray, list[bool]]:
    """Raised-cosine cycles 0 → peak → 0 of PERIOD each (peak 0: a pause), at SIM_FS."""
    t = np.arange(int(PERIOD * SIM_FS)) / SIM_FS
    cycle = 0.5 * (1 - np.cos(2 * np.pi * t / PERIOD))
    return np.concatenate([p * cycle for p in peaks]), [p == FULL for p in peaks]


def steady_truth(u, x, full, n) -> dict[str, float]:
    """Stroke and loop width of the full cycles after the first one of each run (the first
    starts from the anchors a smaller cycle left)."""
    keep = [k for k in range(len(full)) if full[k] and k > 0 and full[k - 1]]
    strokes, widths = [], []
    for k in keep:
        s = slice(k * n, (k + 1) * n)
        stroke = float(np.ptp(x[s]))
        strokes.append(stroke)
        widths.append(100 * branch_gap(u[s], x[s], direction(u[s])) / stroke)
    return {
        "stroke_um": float(np.median(strokes)) * 1e6,
        "loop_width_percent": float(np.median(widths)),
        "cycles": len(keep),
    }


def micromanipulator(rng) -> dict[str, float]:
    peaks = [0.0, 25.0, 50.0, 75.0, *[FULL] * 8, 0.0, 75.0, 50.0, 25.0, *[FULL] * 4]
    u, full = drive(peaks)
    x = twin_position(u)
    fs, every = 200.0, int(SIM_FS / 200.0)
    u_daq, x_daq = u[::every], x[::every]
    t = np.arange(len(u_daq)) / fs
    settling = -4e-6 * np.exp(-t / 0.05)  # the sensor's first 0.2 s
    columns = [
        np.zeros(len(t)),  # a status line, never set during the run
        u_daq / 20 + rng.normal(0.0, 1e-3, len(t)),  # the amplifier's 1:20 monitor [V]
        2.5 + rng.normal(0.0, 2e-3, len(t)),  # a reference voltage
        np.full(len(t), 5.0),  # the sensor's "in range" output
        (x_daq + settling) * 1e6 / 10 + rng.normal(0.0, 2e-4, len(t)),  # 10 µm/V [V]
    ]
    np.savetxt(HERE / "micromanipulator.tsv", np.column_stack(columns), fmt="%.5f", delimiter="\t")
    return steady_truth(u, x, full, int(PERIOD * SIM_FS)) | {"fs": fs, "gain": 20.0}


def tdms(rng) -> dict[str, float]:
    from nptdms import ChannelObject, GroupObject, RootObject, TdmsWriter

    u, full = drive([FULL] * 10)
    x = twin_position(u)
    fs, every = 500.0, int(SIM_FS / 500.0)
    drive_v = u[::every] + rng.normal(0.0, 0.02, len(u[::every]))
    position_um = x[::every] * 1e6 + rng.normal(0.0, 0.01, len(x[::every]))
    waveform = {"wf_increment": 1 / fs, "wf_start_offset": 0.0}
    with TdmsWriter(HERE / "sine_daq.tdms") as writer:
        writer.write_segment(
            [
                RootObject({"name": "sine_daq"}),
                GroupObject("Bench"),
                ChannelObject("Bench", "Drive", drive_v.astype(np.float32), waveform),
                ChannelObject("Bench", "Position", position_um.astype(np.float32), waveform),
            ]
        )
    return steady_truth(u, x, full, int(PERIOD * SIM_FS)) | {"fs": fs}


if __name__ == "__main__":
    rng = np.random.default_rng(2026)
    truth = {"micromanipulator": micromanipulator(rng), "sine_daq": tdms(rng)}
    (HERE / "lab_examples_truth.json").write_text(json.dumps(truth, indent=2) + "\n")
