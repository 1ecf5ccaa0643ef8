"""Digests of short simulated captures, the values the twin writes held to the bit.

Each case simulates a short capture the way the workflow does (a few of the smoke campaign's runs
of both datasets through ``simulate_experiment`` with the shipped ``capture`` settings, an
open-loop capture in chunks that start off the truth's grid, a closed-loop capture through the
compiled real-time loop), and takes, for every variable of the file and of its /truth group, the
SHA-256 of its stored values (the int16 codes as written, the f4 states, the f8 time axes), its
dtype, shape and attributes, and of the file's own attributes. The codec and the chunking are
not in the digest: they change the file's bytes, not the values a reader gets.

An int16 code absorbs most last-bit changes of the values it quantises, and /truth is stored as
float32, so the digests also hold the float64 traces the captures are made from, where a last-bit
change shows (:func:`float_traces`): both twins' kernels, the bench's time-only signals over
chunks in turn, and the measured channels and truth of :meth:`Bench.step` before they are packed.

``twin_capture_digests.json`` beside this script was made with the twin of commit a4774ec (4f6151a
makes the same), from that checkout's folder (its manifests and protocols):

    cd <a checkout of a4774ec> && PYTHONPATH=src $REPO/.venv/bin/python \
        $REPO/tests/data/make_twin_capture_digests.py

(``$REPO``: this repository's folder, where the digests are written). The values depend on the
platform's arithmetic as well as on the twin: numpy's vectorised cos (the drive) and glibc's cos
and sin (the ripple) differ in the last bit from one CPU's instruction set or one libm to another.
The file records where it was made (:func:`platform_key`: the machine, its C library, numpy's
version and the SIMD extensions numpy found), and the test compares only where that is the same.

``tests/unit/test_capture_bits.py`` makes the same captures with the twin of the checkout and holds
them to these digests.
"""

import hashlib
import json
import tempfile
from pathlib import Path

import netCDF4
import numpy as np

HERE = Path(__file__).parent
DIGESTS = HERE / "twin_capture_digests.json"
SHIPPED_CAPTURE = {
    "chunk_len": 65536,
    "compression": "blosc_zstd",
    "complevel": 3,
    "truth_decimation": 12,
}
#: the smoke campaign's runs simulated as the workflow does: (dataset, experiment)
RUNS = (
    ("pi_p885", "ch3_sine_10hz"),  # the ripple channels' run
    ("pi_p885", "ch4_static_blocked"),  # a load stiffness
    ("pi_p885", "ch5_sine_10hz"),  # 72 000 samples: two chunks of the shipped 65 536
    ("pi_p885", "ch7_volt_150hz"),  # the thermometers and the heating
    ("tokin_nb40", "rk_static_hold"),  # the bender
)


def platform_key() -> dict[str, object]:
    """What the captures' last bits depend on besides the twin: the machine, the C library (its
    libm), numpy's version and the SIMD extensions numpy dispatches to on this CPU."""
    import platform

    from numpy._core._multiarray_umath import __cpu_dispatch__, __cpu_features__

    return {
        "machine": platform.machine(),
        "system": platform.system(),
        "libc": "-".join(platform.libc_ver()),
        "numpy": np.__version__,
        "simd": [f for f in __cpu_dispatch__ if __cpu_features__.get(f)],
    }


def _attrs(obj) -> list:
    return sorted((k, repr(np.asarray(obj.getncattr(k)).tolist())) for k in obj.ncattrs())


def digests(path: Path) -> dict[str, str]:
    """{variable (or "/" and "/truth" for the groups' attributes): SHA-256 hex} of a capture."""
    out = {}
    with netCDF4.Dataset(path) as nc:
        groups = [("", nc)] + [(f"{g}/", nc.groups[g]) for g in sorted(nc.groups)]
        for prefix, group in groups:
            out[f"/{prefix}"] = hashlib.sha256(repr(_attrs(group)).encode()).hexdigest()
            for name in sorted(group.variables):
                var = group.variables[name]
                var.set_auto_maskandscale(False)
                values = np.ascontiguousarray(var[:])
                h = hashlib.sha256(repr((values.dtype.str, values.shape, _attrs(var))).encode())
                h.update(values.tobytes())
                out[prefix + name] = h.hexdigest()
    return out


def simulate_cases(folder: Path) -> dict[str, Path]:
    """Every case's capture in ``folder``: {case: path}."""
    import selfsense
    from selfsense.io.manifest import load_dataset
    from selfsense.methods.control import IntegralController
    from selfsense.methods.drive import Drive, Segment
    from selfsense.methods.gamma import GammaPolynomial
    from selfsense.methods.observer import HPOGains
    from selfsense.twin.bench import simulate_capture
    from selfsense.twin.closed_loop import realtime_controller
    from selfsense.twin.experiment import daq_plan, simulate_experiment
    from selfsense.twin.params import TwinParams

    root = Path(selfsense.__file__).parents[2]  # the checkout whose twin runs: its manifests
    paths = {}
    config = {"campaign": "smoke", "capture": SHIPPED_CAPTURE}
    for dataset, experiment in RUNS:
        path = folder / f"{dataset}-{experiment}.nc"
        simulate_experiment(root / "raw", dataset, experiment, config, path)
        paths[f"{dataset}/{experiment}"] = path
    manifest = load_dataset(root / "raw", "pi_p885")
    params, daq = TwinParams.from_manifest(manifest["twin"]), daq_plan(manifest)
    # chunks of 1000 samples start off the truth's grid of 7 and the thermometers' of 4800
    drive = Drive("position", (Segment(0.25, 30.0, 0.0, 20e-6),))
    path = folder / "position-chunks.nc"
    simulate_capture(
        path,
        params,
        daq,
        drive,
        {},
        5,
        "position",
        load_stiffness=2e8,
        chunk_len=1000,
        truth_decimation=7,
        compression="zlib",
        complevel=1,
    )
    paths["position drive, chunks of 1000, truth every 7th"] = path
    s = params.stack
    drive = Drive("position", (Segment(0.05), Segment(0.3, 10.0, 0.0, 15e-6)))
    for chunk_len in (1000, 65536):
        loop = realtime_controller(
            daq,
            drive,
            0.05,
            4,
            GammaPolynomial((-1e6 * s.C_P0 / s.dC_x, 1.0 / s.dC_x)),
            HPOGains(17.0),
            IntegralController(2 * np.pi * 250, s.k / s.alpha),
        )
        path = folder / f"closed-{chunk_len}.nc"
        simulate_capture(
            path, params, daq, drive, {}, 3, "closed", controller=loop, chunk_len=chunk_len
        )
        paths[f"closed loop, chunks of {chunk_len}"] = path
    return paths


def _digest(values) -> str:
    values = np.ascontiguousarray(values)
    h = hashlib.sha256(repr((values.dtype.str, values.shape)).encode())
    h.update(values.tobytes())
    return h.hexdigest()


def float_traces() -> dict[str, dict[str, str]]:
    """{case: {trace: SHA-256 hex}} of the float64 values the captures are made from."""
    import selfsense
    from selfsense.io.manifest import load_dataset
    from selfsense.twin import bender
    from selfsense.twin import kernel as K
    from selfsense.twin.bench import Bench, experiment_seed
    from selfsense.twin.experiment import daq_plan
    from selfsense.twin.params import TwinParams

    root = Path(selfsense.__file__).parents[2]
    manifest = load_dataset(root / "raw", "pi_p885")
    params, daq = TwinParams.from_manifest(manifest["twin"]), daq_plan(manifest)
    t = np.arange(24000) / daq.fs
    U = 50 - 50 * np.cos(2 * np.pi * 230 * t) + 20 * (t > 0.2) + 30 * np.sin(2 * np.pi * 7 * t)
    out = {}
    for load in (0.0, 2e8):
        kc = K.kernel_constants(params, daq.fs, load)
        state = K.initial_state(kc, params.thermal.T_amb)
        ambient = np.full_like(U, params.thermal.T_amb)
        trace = K.run(U, 1e3 * np.sin(2 * np.pi * 3 * t), ambient, kc, state)
        out[f"stack kernel, load {load:g} N/m"] = {"out": _digest(trace), "state": _digest(state)}
    bench = Bench(params, daq, experiment_seed(7, "traces"))
    traces, start = {}, 0
    for n in (65536, 1000, 30011):
        tc = (start + np.arange(n)) / daq.fs
        start += n
        for k, v in bench.time_signals(tc).items():
            traces[f"{n}: {k}"] = _digest(v)
    traces["ripple phase"] = repr(bench.ripple.phase)
    out["time-only signals, chunks of 65536, 1000, 30011"] = traces
    bench = Bench(params, daq, experiment_seed(8, "step"))
    steps, start = {}, 0
    for n in (65536, 4321):
        tc = (start + np.arange(n)) / daq.fs
        start += n
        measured, truth = bench.step(tc, 50 - 50 * np.cos(2 * np.pi * 50 * tc), truth_every=1)
        steps |= {f"{n}: {k}": _digest(v) for k, v in (measured | truth).items()}
    out["Bench.step before packing, chunks of 65536, 4321"] = steps
    tokin = load_dataset(root / "raw", "tokin_nb40")
    bp = bender.BenderParams.from_manifest(tokin["twin"])
    fs = float(tokin["daq"]["fs"])
    tb = np.arange(6000) / fs
    for mode, drive in (
        ("voltage", 100 * np.sin(2 * np.pi * 0.5 * tb)),
        ("current", 3e-7 + 0 * tb),
    ):
        kc = bender.kernel_constants(bp, fs)
        state = bender.initial_state(kc)
        noise = 1e-12 * np.random.default_rng(3).standard_normal(len(tb))
        trace = bender.run(mode, drive, noise, kc, state)
        out[f"bender kernel, {mode} drive"] = {"out": _digest(trace), "state": _digest(state)}
    return out


def main() -> None:
    with tempfile.TemporaryDirectory() as tmp:
        cases = {case: digests(path) for case, path in simulate_cases(Path(tmp)).items()}
    cases |= float_traces()
    made = {"made_on": platform_key(), "cases": cases}
    DIGESTS.write_text(json.dumps(made, indent=1, sort_keys=True) + "\n")


if __name__ == "__main__":
    main()
