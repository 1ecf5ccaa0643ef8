"""A manifest's protocol overrides (an envelope member's drawn levels and record lengths) held to
the protocol schema's limits after they are applied, and a simulated capture's size bounded
before it is written: one line naming the manifest and the key, nothing in raw/."""

import shutil
import time

import pytest
import yaml

from selfsense.io.manifest import ManifestError, catalogue, load_config, load_dataset
from selfsense.twin import experiment as twin

from ..helpers import ROOT, one_line

RUN = "ch3:experiments.ch3_sine_10hz"
ABOVE = "1000000000.0 is greater than the maximum of"
CONFIG = load_config(ROOT / "tests" / "config" / "smoke.yaml")


@pytest.fixture
def raw(tmp_path, monkeypatch):
    """raw/pi_p885/dataset.yaml alone (no captures) in a checkout at tmp_path whose
    workflow/protocols is the repository's."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "workflow").mkdir()
    (tmp_path / "workflow" / "protocols").symlink_to(ROOT / "workflow" / "protocols")
    (tmp_path / "raw" / "pi_p885").mkdir(parents=True)
    shutil.copy(ROOT / "raw" / "pi_p885" / "dataset.yaml", tmp_path / "raw" / "pi_p885")
    return tmp_path / "raw"


def with_overrides(raw, overrides):
    path = raw / "pi_p885" / "dataset.yaml"
    doc = yaml.safe_load(path.read_text()) | {"protocol_overrides": overrides}
    path.write_text(yaml.safe_dump(doc, allow_unicode=True))
    return path


def simulated(raw, experiment="ch3_sine_10hz"):
    """Simulate one run as rule simulate does; the one line it stops with."""
    with pytest.raises(ManifestError) as e:
        twin.simulate_experiment(raw, "pi_p885", experiment, CONFIG)
    return str(e.value)


FAULTS = [  # the override, the value, what the line says
    pytest.param("segments.0.duration", 1e12, "is greater than the maximum of 12000", id="1e12 s"),
    pytest.param("smoke.segments.0.duration", 1e12, "greater than the maximum", id="smoke 1e12"),
    pytest.param("segments.0.duration", -5, "-5 is less than or equal to the minimum", id="-5"),
    pytest.param("segments.0.duration", 0, "0 is less than or equal to the minimum of 0", id="0"),
    pytest.param(
        "segments.first.duration",
        1.0,
        "'first' is not an index of the list there, which has 1 element (0 to 0)",
        id="a word as an index",
    ),
    pytest.param(
        "segments.9.duration", 1.0, "'9' is not an index of the list there", id="past the end"
    ),
    pytest.param("segments.-1.duration", 1.0, "'-1' is not an index", id="a negative index"),
    pytest.param("segments.².duration", 1.0, "'²' is not an index", id="a superscript digit"),
    pytest.param("segments.0.frequency", -10, "-10 is less than the minimum of 0", id="-10 Hz"),
]


@pytest.mark.parametrize("key,value,said", FAULTS)
def test_a_bad_override_is_one_line_naming_the_manifest_and_key_and_nothing_is_written(
    raw, key, value, said
):
    path = with_overrides(raw, {f"{RUN}.{key}": value})
    line = simulated(raw)
    one_line(line, path, f"key protocol_overrides.{RUN}.{key}: ", said)
    assert sorted(p.name for p in (raw / "pi_p885").iterdir()) == ["dataset.yaml"]


@pytest.mark.parametrize(
    "key,value,said",
    [
        ("ch4:experiments.ch4_sine_10hz.sets", 2.5, "2.5 is not of type 'integer'"),
        ("ch4:experiments.ch4_sine_10hz.sets", 1e9, f"{ABOVE} 100"),
        ("ch6:experiments.ch6_p1_open.repeat", 1e9, f"{ABOVE} 1000"),
        ("ch6:experiments.ch6_p1_open.warmup", -1, "-1 is less than the minimum of 0"),
    ],
)
def test_counts_and_warmups_are_bounded_too_and_a_billion_sets_never_hang(key, value, said):
    """A drawn ``sets: 1e9`` would build a billion experiments at the workflow's parse."""
    manifest = load_dataset(ROOT / "raw", "pi_p885")
    began = time.perf_counter()
    with pytest.raises(ManifestError) as e:
        catalogue(manifest | {"protocol_overrides": {key: value}}, "smoke", "m.yaml")
    assert time.perf_counter() - began < 2
    one_line(str(e.value), "m.yaml", f"key protocol_overrides.{key}: {said}")


def test_overrides_within_the_limits_still_apply():
    manifest = load_dataset(ROOT / "raw", "pi_p885")
    overrides = {f"{RUN}.segments.0.duration": 2.5, f"{RUN}.segments.0.hi": 90.0}
    run = catalogue(manifest | {"protocol_overrides": overrides}, "thesis", "m.yaml")
    assert run["ch3_sine_10hz"].protocol["segments"][0] == {
        "duration": 2.5,
        "frequency": 10,
        "lo": 0,
        "hi": 90.0,
    }


def test_a_capture_beyond_the_stated_size_is_refused_before_the_writer_opens(raw, monkeypatch):
    """6 000 s is within the schema's bound on a segment (12 000 s) but, at 48 kHz, 288 M samples:
    more than MAX_CAPTURE_SAMPLES (268 M), refused before anything is simulated or written."""
    began = []
    monkeypatch.setattr(twin, "_simulate", lambda *args, **kwargs: began.append(args))
    path = with_overrides(raw, {f"{RUN}.smoke.segments.0.duration": 6000.0})
    line = simulated(raw)
    one_line(
        line,
        path,
        f"key protocol_overrides.{RUN}.smoke.segments.0.duration: experiment ch3_sine_10hz "
        "would record 2.88e+08 samples (6000 s at daq.fs = 48000 Hz), more than a capture may "
        f"hold ({twin.MAX_CAPTURE_SAMPLES}",
    )
    assert began == []
    assert sorted(p.name for p in (raw / "pi_p885").iterdir()) == ["dataset.yaml"]


def test_every_capture_of_the_thesis_campaign_is_within_the_stated_size():
    manifest = load_dataset(ROOT / "raw", "pi_p885")
    for run in catalogue(manifest, "thesis").values():
        twin._check_capture_size(run, manifest, "m.yaml")  # raises beyond the bound


def test_a_protocol_file_that_sets_the_length_is_the_one_named(monkeypatch):
    """Without an override of the run, its protocol file set its length, and is named."""
    manifest = load_dataset(ROOT / "raw", "pi_p885")
    monkeypatch.setattr(twin, "MAX_CAPTURE_SAMPLES", 1000)
    run = catalogue(manifest, "smoke")["ch4_sine_10hz_s2"]
    with pytest.raises(ManifestError) as e:
        twin._check_capture_size(run, manifest, "m.yaml")
    one_line(str(e.value), "workflow/protocols/ch4.yaml: key experiments.ch4_sine_10hz: ")
