"""Hostile YAML: an alias bomb, a key given twice, a protocol name that climbs out of the
catalogue. Each is refused with one line naming the file, quickly, reading nothing it should
not."""

import shutil
import time
from pathlib import Path

import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from selfsense.io import manifest as manifest_module
from selfsense.io.manifest import (
    MAX_YAML_NODES,
    ManifestError,
    expand_protocols,
    load_dataset,
    load_yaml,
    validate_document,
)

from ..helpers import ROOT, manifest, one_line

#: every YAML the repository ships: manifests, configs, the catalogue, registries and schemas
SHIPPED = sorted(
    [
        *ROOT.glob("raw/*/dataset.yaml"),
        ROOT / "config.yaml",
        *ROOT.glob("workflow/*.yaml"),
        *ROOT.glob("workflow/protocols/*.yaml"),
        *ROOT.glob("tests/config/*.yaml"),
        *ROOT.glob("src/selfsense/io/schemas/*.yaml"),
    ]
)


def write(folder: Path, text: str, name: str = "dataset.yaml") -> Path:
    path = folder / name
    path.write_text(text, encoding="utf-8")
    return path


def refused(path, *fragments) -> str:
    with pytest.raises(ManifestError) as e:
        load_yaml(path)
    one_line(str(e.value), path, *fragments)
    return str(e.value)


# -- aliases --------------------------------------------------------------------------------------


def alias_bomb(levels: int = 9, fan: int = 9) -> str:
    """A manifest's head, then nine lists of nine aliases of the list before: ≈ 750 bytes that
    expand to 9⁹ ≈ 3.9e8 nodes."""
    lines = [
        "name: bomb",
        "description: >-",
        "  nine lists of nine aliases of the list before, nine deep: 750 bytes that every walk",
        "  of the loaded document (the finite-value check, the schema) visits as 9^9 nodes",
        "source: measured",
        "daq: {fs: 48000, channels: [U], ranges: {U: [-10, 10]}}",
        "protocols: [ch3]",
        "lol:",
        f"  - &l0 [{', '.join(['lol'] * fan)}]",
    ]
    for k in range(1, levels):
        lines.append(f"  - &l{k} [{', '.join([f'*l{k - 1}'] * fan)}]")
    return "\n".join(lines) + "\n"


def test_the_alias_bomb_is_refused_in_under_a_second(tmp_path):
    text = alias_bomb()
    assert 700 <= len(text.encode()) <= 800
    path = write(tmp_path, text)
    start = time.perf_counter()
    with pytest.raises(ManifestError) as e:
        load_yaml(path)
    elapsed = time.perf_counter() - start
    one_line(
        str(e.value), path, f"expands to more than {MAX_YAML_NODES} nodes through YAML aliases"
    )
    assert elapsed < 1.0, f"{elapsed:.3f} s"  # before: loaded in 1 ms, then walked for hours


def test_the_alias_bomb_through_merge_keys_is_refused(tmp_path):
    lines = ["m0: &m0 {a: 1, b: 2, c: 3, d: 4, e: 5, f: 6, g: 7, h: 8, i: 9}"]
    for k in range(1, 9):
        merged = ", ".join(f"{{<<: *m{k - 1}}}" for _ in range(9))
        lines.append(f"m{k}: &m{k} {{x: [{merged}]}}")
    refused(write(tmp_path, "\n".join(lines) + "\n"), "through YAML aliases")


def test_a_small_aliased_manifest_loads(tmp_path):
    """Aliases are legal YAML (the catalogue uses them): only the budget refuses."""
    text = alias_bomb(levels=3, fan=9)  # 9³ nodes and a few
    doc = load_yaml(write(tmp_path, text))
    assert len(doc["lol"]) == 3 and doc["lol"][2][8][8] == doc["lol"][0]
    merged = "base: &b {a: 1, b: 2}\nmid: &m {<<: *b, a: 2}\ntop: {<<: *m, b: 3, c: 4}\nagain: *m\n"
    doc = load_yaml(write(tmp_path, merged, "merged.yaml"))
    assert doc["mid"] == {"a": 2, "b": 2}
    assert doc["top"] == {"a": 2, "b": 3, "c": 4}
    assert doc["again"] == doc["mid"]


def test_an_alias_inside_its_own_anchor_is_refused(tmp_path):
    # PyYAML builds a list that contains itself: every walk of it recurses forever
    refused(write(tmp_path, "name: &a [1, *a]\n"), "alias *a at line 1", "contains itself")


def test_nesting_through_aliases_counts_against_the_depth_bound(tmp_path):
    deep = "[" * 60 + "]" * 60
    text = f"a: &a {deep}\nb: {'[' * 60}*a{']' * 60}\n"  # 60 + 60 levels once expanded
    refused(write(tmp_path, text), "nested deeper than 100 levels through YAML aliases")


@pytest.mark.parametrize("path", SHIPPED, ids=lambda p: str(p.relative_to(ROOT)))
def test_the_budget_is_far_above_every_shipped_yaml(path, monkeypatch):
    """Each shipped YAML loads with a tenth of the budget (the largest, workflow/scorecard.yaml,
    has 7 579 nodes)."""
    monkeypatch.setattr(manifest_module, "MAX_YAML_NODES", MAX_YAML_NODES // 10)
    assert load_yaml(path)


# -- keys given twice -----------------------------------------------------------------------------


def test_a_top_level_key_given_twice_is_refused(tmp_path):
    head = yaml.safe_dump(manifest("bench", ["sine_1hz"]), sort_keys=False)
    text = head + "experiments: [sine_2hz]\n"  # appended by hand
    line = text.count("\n")
    path = write(tmp_path, text)
    assert refused(path) == f"{path}: key experiments given twice (line {line})"


@pytest.mark.parametrize(
    "text, key, line",
    [
        ("daq:\n  fs: 48000\n  channels: [U]\n  fs: 96000\n", "fs", 4),
        ("daq: {fs: 48000, fs: 96000}\n", "fs", 1),
        ("a:\n  - {x: 1}\n  - {y: 2, y: 3}\n", "y", 3),
        ("base: &b {a: 1}\nd: {<<: *b, a: 2, a: 3}\n", "a", 2),
        ('"a\\nb": 1\n"a\\nb": 2\n', "'a\\nb'", 2),
    ],
    ids=["nested", "flow", "in a list", "beside a merge", "with a line break"],
)
def test_a_nested_key_given_twice_is_refused(tmp_path, text, key, line):
    path = write(tmp_path, text)
    refused(path, f"key {key} given twice (line {line})")


def test_an_override_of_a_merged_key_is_not_a_key_given_twice(tmp_path):
    doc = load_yaml(write(tmp_path, "base: &b {a: 1, b: 2}\nd: {<<: *b, a: 3}\n"))
    assert doc["d"] == {"a": 3, "b": 2}


@pytest.mark.parametrize("path", SHIPPED, ids=lambda p: str(p.relative_to(ROOT)))
def test_every_shipped_yaml_loads(path):
    assert load_yaml(path)


def test_the_loader_still_reads_yaml_1_2_floats(tmp_path):
    doc = load_yaml(write(tmp_path, "fs: 4.8e4\nc: 3.4e7\nd: -1E-6\ns: '1e5'\n"))
    assert doc == {"fs": 48000.0, "c": 3.4e7, "d": -1e-6, "s": "1e5"}


# -- protocol names -------------------------------------------------------------------------------

SECRET = "hunter2-do-not-print-me"


@pytest.fixture
def repo(tmp_path, monkeypatch):
    """A folder to run in with a catalogue of ch3 and ch4, and a YAML outside it holding a
    secret, which the manifests below try to reach."""
    folder = tmp_path / "a" / "repo"
    shutil.copytree(ROOT / "workflow" / "protocols", folder / "workflow" / "protocols")
    for extra in (folder / "workflow" / "protocols").glob("*.yaml"):
        if extra.stem not in ("ch3", "ch4"):
            extra.unlink()
    (folder.parent / "x").mkdir()  # workflow/protocols/../../../x/evil.yaml
    (folder.parent / "x" / "evil.yaml").write_text(f"{SECRET}: [{SECRET}]\n")
    monkeypatch.chdir(folder)
    return folder


def bench(repo, protocols):
    folder = repo / "raw" / "bench"
    folder.mkdir(parents=True, exist_ok=True)
    doc = manifest("bench", [], protocols=protocols)
    return write(folder, yaml.safe_dump(doc, sort_keys=False))


@pytest.fixture
def opened(monkeypatch):
    """The files load_yaml opens from here on."""
    paths = []

    def spy(path):
        paths.append(Path(path).resolve())
        return load_yaml(path)

    monkeypatch.setattr(manifest_module, "load_yaml", spy)
    return paths


@pytest.mark.parametrize(
    "name",
    ["../../../x/evil", "../evil", "/etc/passwd", "ch3/../../../../x/evil", "..", "ch3\n", ""],
)
def test_a_protocol_name_outside_the_catalogue_is_refused_before_any_file_is_read(
    repo, opened, name
):
    path = bench(repo, ["ch3", name])
    with pytest.raises(ManifestError) as e:
        load_dataset(repo / "raw", "bench")
    message = str(e.value)
    one_line(message, path, f"protocols: {name!r} is not a protocol name", "catalogue has ch3, ch4")
    assert SECRET not in message
    assert not any(p.is_relative_to(repo.parent / "x") for p in opened), opened


def test_expand_protocols_never_opens_a_file_outside_its_catalogue(repo, opened):
    directory = repo / "workflow" / "protocols"
    assert (directory / "../../../x/evil.yaml").resolve().read_text().startswith(SECRET)
    with pytest.raises(ManifestError) as e:
        expand_protocols(["../../../x/evil"], "thesis", directory, source="raw/bench/dataset.yaml")
    one_line(str(e.value), "raw/bench/dataset.yaml", "'../../../x/evil' is not a protocol name")
    assert SECRET not in str(e.value)
    assert opened == []
    with pytest.raises(ManifestError) as e:  # without a manifest to blame: the catalogue
        expand_protocols(["ch3", "../../../x/evil"], "thesis", directory)
    one_line(str(e.value), directory, "is not a protocol name")
    assert opened == []  # not even ch3: every name is checked first


def test_a_protocol_missing_from_the_catalogue_is_refused(repo, opened):
    path = bench(repo, ["ch3", "ch9"])
    with pytest.raises(ManifestError) as e:
        load_dataset(repo / "raw", "bench")
    one_line(
        str(e.value),
        path,
        "protocols: 'ch9' is not in the catalogue workflow/protocols (the catalogue has ch3, ch4)",
    )


def test_the_catalogue_protocols_still_expand(repo):
    bench(repo, ["ch3", "ch4"])
    doc = load_dataset(repo / "raw", "bench")
    catalogue = expand_protocols(doc["protocols"], "smoke")
    assert {e.chapter for e in catalogue.values()} == {"ch3", "ch4"}


# -- anything at all ------------------------------------------------------------------------------

TOKENS = [
    "a", "b", "name", "1", "-1", "1e5", "0x1F", "1_0", ".nan", ".inf", "~", "null", "yes",
    ": ", ":", "- ", "-", "\n", "  ", "\t", "[", "]", "{", "}", ", ", "? ",
    "&a ", "*a", "&b ", "*b", "<<: ", "!!int ", "!!float ", "!!str ", "!!timestamp ",
    "!!binary ", "!!set ", "!!omap ", "!!python/object:os.system ", "!x ", "2024-02-30",
    "2024-01-01 10:00:00", "|", ">", "'", '"', "\\", "#", "%YAML 1.2\n", "---\n", "...\n",
    "@", "`", "\ufeff", "\x85", "\x00", "é", "9" * 40,
]  # fmt: skip


@settings(
    max_examples=300,
    deadline=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture],
)
@given(
    text=st.one_of(
        st.lists(st.sampled_from(TOKENS), max_size=60).map("".join),
        st.text(st.characters(blacklist_categories=("Cs",)), max_size=200),
    )
)
def test_any_text_loads_or_is_refused_with_one_line(tmp_path, text):
    path = write(tmp_path, text)
    start = time.perf_counter()
    try:
        doc = load_yaml(path)
        validate_document(doc, "dataset.schema.yaml", path)
    except ManifestError as err:
        one_line(str(err), path)
    assert time.perf_counter() - start < 2.0
