import shutil
from pathlib import Path

import numpy as np
import pytest

from selfsense.manifest import load_dataset
from selfsense.twin import TwinParams, daq_plan

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="session")
def stack_manifest():
    return load_dataset(ROOT / "raw", "pi_p885")


@pytest.fixture(scope="session")
def stack_params(stack_manifest):
    return TwinParams.from_manifest(stack_manifest["twin"])


@pytest.fixture(scope="session")
def stack_daq(stack_manifest):
    return daq_plan(stack_manifest)


def raised_sine(f, duration, fs=48000.0, hi=100.0):
    t = np.arange(int(round(duration * fs))) / fs
    return t, hi * 0.5 * (1 - np.cos(2 * np.pi * f * t))


@pytest.fixture
def repo_copy(tmp_path):
    """A copy of the repository's workflow files (no results, no captures) to run Snakemake in."""
    dest = tmp_path / "repo"
    ignore = shutil.ignore_patterns(".venv", ".git", ".snakemake", "results", "figures", "logs",
                                    "*.nc", "out", "__pycache__", ".hypothesis", ".pytest_cache")
    shutil.copytree(ROOT, dest, ignore=ignore)
    return dest
