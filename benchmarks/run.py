"""Throughput and memory figures of the pipeline's hot paths, printed for benchmarks/README.md.

    .venv/bin/python benchmarks/run.py [--seconds 20]

Prints: the twin kernel (samples/s per core), a whole simulated capture (samples/s), capture
write and read throughput with and without zlib, ripple extraction and HPO throughput with their
ratio to just reading the channels they consume, and the peak memory of `simulate` for a capture
and one 10× longer (each in a fresh process, so peaks do not mix).
"""

from __future__ import annotations

import argparse
import platform
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
FS = 48000.0


def best_of(fn, repeats=3):
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def params():
    from selfsense.manifest import load_dataset
    from selfsense.twin import TwinParams, daq_plan

    manifest = load_dataset(ROOT / "raw", "pi_p885")
    return TwinParams.from_manifest(manifest["twin"]), daq_plan(manifest)


def bench_kernel(seconds):
    from selfsense.twin import kernel as K

    p, _ = params()
    n = int(seconds * FS)
    U = 50 - 50 * np.cos(2 * np.pi * 50 * np.arange(n) / FS)
    kc = K.kernel_constants(p, FS)
    K.run(U[:100], U[:100] * 0, U[:100] * 0 + 23, kc, K.initial_state(kc, 23.0))  # compile
    t = best_of(lambda: K.run(U, 0 * U, 0 * U + 23, kc, K.initial_state(kc, 23.0)))
    print(f"twin kernel (numba, 1 core):           {n / t / 1e6:8.2f} M samples/s")


def simulate(path, seconds, zlib=True):
    from selfsense.twin import Drive, simulate_capture
    from selfsense.twin.drive import Segment

    p, daq = params()
    drive = Drive("voltage", (Segment(seconds, 50.0, 0.0, 100.0),))
    return simulate_capture(path, p, daq, drive, {}, 1, "bench", zlib=zlib)


def bench_capture(seconds, tmp):
    from selfsense.capture import open_capture

    n = int(seconds * FS)
    for zlib in (True, False):
        path = tmp / f"cap_{zlib}.nc"
        t = best_of(lambda: simulate(path, seconds, zlib), repeats=1)
        label = "zlib" if zlib else "none"
        print(f"simulate whole capture ({label:4s}, 9 ch):   {n / t / 1e6:8.2f} M time steps/s "
              f"({path.stat().st_size / n / 9:.2f} B/sample)")

        def read():
            with open_capture(path) as cap:
                for _ in cap.iter_chunks(["U", "I", "Ur", "Ir", "x_laser", "F"]):
                    pass
        t = best_of(read)
        print(f"read+unpack 6 channels ({label}):          {6 * n / t / 1e6:8.2f} M samples/s")
    return tmp / "cap_True.nc"


def bench_ripple_and_hpo(path):
    from selfsense.capture import open_capture
    from selfsense.observer import HPOGains, HybridPositionObserver
    from selfsense.ripple import RippleExtractor, SamplingPlan

    def read(names):
        with open_capture(path) as cap:
            for _ in cap.iter_chunks(names):
                pass

    with open_capture(path) as cap:
        n = cap.n
        data = cap.read(["Ur", "Ir", "I"])
    t_read = best_of(lambda: read(["Ur", "Ir"]))
    chunk = 1 << 18

    def ripple():
        ex = RippleExtractor(SamplingPlan(1e5, 12, 4, 4))
        for s in range(0, n, chunk):
            ex.process(data["Ur"][s:s + chunk], data["Ir"][s:s + chunk])
    t_rip = best_of(ripple)
    print(f"ripple extraction (np=4, 1 core):      {2 * n / t_rip / 1e6:8.2f} M samples/s "
          f"= {t_read / t_rip:.2f}× reading Ur+Ir ({2 * n / t_read / 1e6:.1f} M/s)")

    obs = HybridPositionObserver(HPOGains(17.0), FS)
    xcp = np.zeros(n)
    obs.step(data["I"][:100], xcp[:100])
    t_hpo = best_of(lambda: obs.step(data["I"], xcp))
    t_read_i = best_of(lambda: read(["I"]))
    print(f"HPO (numba, 1 core):                   {n / t_hpo / 1e6:8.2f} M samples/s "
          f"= {t_read_i / t_hpo:.2f}× reading I")


def peak_memory_of_simulate(seconds):
    code = (f"import sys, resource; sys.path.insert(0, {str(ROOT / 'benchmarks')!r}); import run; "
            f"run.simulate({str(Path(tempfile.gettempdir()) / 'mem.nc')!r}, {seconds}); "
            "print(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    return int(out.stdout.split()[-1]) / 1024


def main():
    cli = argparse.ArgumentParser(description=__doc__)
    cli.add_argument("--seconds", type=float, default=20.0, help="capture length for throughput")
    args = cli.parse_args()
    print(f"machine: {platform.machine()}, {platform.processor() or '?'}, python {platform.python_version()}")
    bench_kernel(args.seconds)
    with tempfile.TemporaryDirectory() as tmp:
        path = bench_capture(args.seconds, Path(tmp))
        bench_ripple_and_hpo(path)
    short, long = peak_memory_of_simulate(args.seconds), peak_memory_of_simulate(10 * args.seconds)
    print(f"simulate peak RSS: {short:.0f} MB for {args.seconds:g} s, {long:.0f} MB for "
          f"{10 * args.seconds:g} s (ratio {long / short:.2f})")


if __name__ == "__main__":
    main()
