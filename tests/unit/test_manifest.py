"""Config, manifest and catalogue validation: one line naming the file and the key."""

import shutil

import pytest
import yaml

from selfsense.io.manifest import ManifestError, expand_protocols, load_config, load_dataset

from ..helpers import ROOT


def write_config(tmp_path, **changes):
    config = yaml.safe_load((ROOT / "config.yaml").read_text()) | changes
    path = tmp_path / "config.yaml"
    path.write_text(yaml.safe_dump(config))
    return path


def assert_one_line(excinfo, *fragments):
    msg = str(excinfo.value)
    assert "\n" not in msg
    for f in fragments:
        assert f in msg, msg


def test_repository_config_is_valid_and_gets_defaults():
    config = load_config(ROOT / "config.yaml")
    assert config["raw_dir"] == "raw"
    assert config["resources"]["stream"] == {"mem_mb": 1500, "runtime": 30}


def test_misspelt_key(tmp_path):
    path = write_config(tmp_path, campain="smoke")
    with pytest.raises(ManifestError) as e:
        load_config(path)
    assert_one_line(e, str(path), "unknown key campain")


def test_misspelt_nested_key(tmp_path):
    path = write_config(tmp_path, ripple={"n_period": 4})
    with pytest.raises(ManifestError) as e:
        load_config(path)
    assert_one_line(e, str(path), "unknown key ripple.n_period")


def test_wrong_type(tmp_path):
    path = write_config(tmp_path, ripple={"n_periods": "four"})
    with pytest.raises(ManifestError) as e:
        load_config(path)
    assert_one_line(e, str(path), "ripple.n_periods", "not of type 'integer'")


def test_missing_required_field(tmp_path):
    config = yaml.safe_load((ROOT / "config.yaml").read_text())
    del config["campaign"]
    path = tmp_path / "config.yaml"
    path.write_text(yaml.safe_dump(config))
    with pytest.raises(ManifestError) as e:
        load_config(path)
    assert_one_line(e, str(path), "'campaign' is a required property")


@pytest.mark.parametrize("name", ["../etc", "a/b", ".hidden"])
def test_dataset_name_with_path_separator_or_dots(tmp_path, name):
    path = write_config(tmp_path, datasets=[name])
    with pytest.raises(ManifestError) as e:
        load_config(path)
    assert_one_line(e, str(path), "no path separators")


def test_unknown_dataset(tmp_path):
    with pytest.raises(ManifestError) as e:
        load_dataset(tmp_path, "nope")
    assert_one_line(e, "unknown dataset 'nope'")


def test_manifest_with_a_wrong_type(tmp_path):
    shutil.copytree(
        ROOT / "raw" / "pi_p885", tmp_path / "pi_p885", ignore=shutil.ignore_patterns("*.nc")
    )
    path = tmp_path / "pi_p885" / "dataset.yaml"
    path.write_text(path.read_text().replace("fs: 48000.0", "fs: fast"))
    with pytest.raises(ManifestError) as e:
        load_dataset(tmp_path, "pi_p885")
    assert_one_line(e, str(path), "daq.fs")


def test_manifest_name_must_match_folder(tmp_path):
    shutil.copytree(
        ROOT / "raw" / "pi_p885", tmp_path / "other", ignore=shutil.ignore_patterns("*.nc")
    )
    with pytest.raises(ManifestError) as e:
        load_dataset(tmp_path, "other")
    assert_one_line(e, "does not match its folder")


def test_catalogue_expands_sets_and_applies_smoke():
    thesis = expand_protocols(["ch4"], "thesis")
    smoke = expand_protocols(["ch4"], "smoke")
    assert [f"ch4_sine_10hz_s{k}" for k in range(1, 6)] == [
        n for n in thesis if n.startswith("ch4_sine_10hz")
    ]
    assert [n for n in smoke if n.startswith("ch4_sine_10hz")] == [
        "ch4_sine_10hz_s1",
        "ch4_sine_10hz_s2",
    ]
    assert thesis["ch4_static_blocked"].load_stiffness == 1.05e9


def test_every_chapter_catalogue_is_valid():
    catalogue = expand_protocols(["ch3", "ch4", "ch5", "ch6", "ch7"], "thesis")
    # P1's 50 tests are one recording each for the open and the closed loop
    assert [n for n in catalogue if n.startswith("ch6_p1_")] == ["ch6_p1_open", "ch6_p1_closed"]
    assert catalogue["ch6_p1_open"].protocol["repeat"] == 50
    creep = catalogue["ch5_creep"].protocol["segments"]
    assert creep[1]["duration"] == 175.0
