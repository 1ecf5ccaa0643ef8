"""The envelope's declared unknowns (workflow/unknowns.yaml): the shipped file loads and says where
each value lives, what it is today and why its range; the loader refuses a declaration without a
range or a source, out of order, or drifted from the file it names, in one line naming the file
and the entry; the hash follows the file's bytes."""

import copy
import hashlib
import re

import numpy as np
import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st

from selfsense.envelope.design import physical
from selfsense.envelope.unknowns import load_unknowns, unknowns_hash
from selfsense.io.manifest import ManifestError, load_dataset, load_yaml, schema_default

from ..helpers import ROOT

UNKNOWNS = ROOT / "workflow" / "unknowns.yaml"


@pytest.fixture(scope="module")
def unknowns():
    return load_unknowns(UNKNOWNS)


@pytest.fixture(scope="module")
def document():
    return load_yaml(UNKNOWNS)


def write(tmp_path, doc, name="unknowns.yaml"):
    path = tmp_path / name
    path.write_text(yaml.safe_dump(doc, allow_unicode=True, sort_keys=False), encoding="utf-8")
    return path


def only(document, uid):
    """A copy of the shipped file with one entry, ``uid`` (each refusal test mutates one entry:
    the others would only be read again)."""
    doc = copy.deepcopy(document)
    doc["unknowns"] = [e for e in doc["unknowns"] if e["id"] == uid]
    return doc


def refusal(tmp_path, doc):
    """The one-line refusal of a mutated copy of the shipped file."""
    path = write(tmp_path, doc)
    with pytest.raises(ManifestError) as err:
        load_unknowns(path, root=ROOT)
    message = str(err.value)
    assert "\n" not in message
    assert message.startswith(f"{path}: ")
    return message


# --- the shipped file -----------------------------------------------------------------------------


def test_shipped_file_loads(unknowns):
    assert len(unknowns) >= 40
    ids = [u.id for u in unknowns]
    assert len(ids) == len(set(ids))
    for u in unknowns:
        assert u.source.strip(), u.id
        assert u.low < u.high, u.id
        assert u.low <= u.nominal <= u.high, u.id
        assert u.kind in {"uniform", "loguniform", "integer", "normal"}, u.id
        assert u.unit and u.affects and u.paths, u.id


def test_every_entry_has_range_or_distribution_and_source(document):
    for entry in document["unknowns"]:
        assert ("range" in entry) != ("distribution" in entry), entry["id"]
        assert entry["source"].strip(), entry["id"]


def _value(doc, key):
    """The value at a dotted key; a twin variant's key a manifest leaves out holds the dataset
    schema's default, the term off."""
    node = doc
    try:
        for part in key.split("."):
            node = node[int(part)] if isinstance(node, list) else node[part]
    except KeyError:
        return schema_default("dataset.schema.yaml", key.split("."))
    return node


def test_nominal_is_what_the_files_hold(unknowns):
    """Checked here without the loader: every manifest and protocol location holds the nominal."""
    manifests = {d: load_dataset(ROOT / "raw", d) for d in ("pi_p885", "tokin_nb40")}
    protocols = {}
    checked = 0
    for u in unknowns:
        for location in u.paths:
            if location.startswith("model:"):
                assert (ROOT / u.where).is_file(), u.id
                continue
            if location.startswith("protocols/"):
                file, key = location.split(":", 1)
                if file not in protocols:
                    protocols[file] = load_yaml(ROOT / "workflow" / file)
                docs = [protocols[file]]
            else:
                key, docs = location, [manifests[d] for d in u.datasets]
            for doc in docs:
                assert _value(doc, key) == pytest.approx(u.nominal, rel=1e-12, abs=0), (
                    u.id,
                    location,
                )
                checked += 1
    assert checked >= len(unknowns)


def _assumed_keys(manifest_text):
    """Dotted keys of a manifest whose line's comment says the value is assumed."""
    stack, keys = [], []
    for line in manifest_text.splitlines():
        match = re.match(r"^( *)([A-Za-z_][A-Za-z0-9_]*):", line)
        if not match:
            continue
        depth = len(match.group(1)) // 2
        stack[depth:] = [match.group(2)]
        if "#" in line and "assumed" in line.split("#", 1)[1]:
            keys.append(".".join(stack))
    return keys


@pytest.mark.parametrize("dataset", ["pi_p885", "tokin_nb40"])
def test_every_assumed_value_is_declared(unknowns, dataset):
    assumed = _assumed_keys((ROOT / "raw" / dataset / "dataset.yaml").read_text(encoding="utf-8"))
    assert assumed, f"raw/{dataset}/dataset.yaml marks nothing assumed: the test reads it wrong"
    declared = {p for u in unknowns if dataset in u.datasets for p in u.paths}
    assert not [k for k in assumed if k not in declared]


def test_every_calibrated_parameter_is_declared_within_its_search(unknowns):
    """The calibration's free parameters, each with its range's derivation, inside the search
    range the calibration may move it in (a range wider than the search would claim more than the
    signatures were asked)."""
    free = load_yaml(ROOT / "workflow" / "twin_calibration.yaml")["free"]
    by_path = {p: u for u in unknowns if "pi_p885" in u.datasets for p in u.paths}
    for name, (low, high) in free.items():
        u = by_path[f"twin.{name}"]
        assert u.derivation, u.id
        assert low <= u.low < u.high <= high, u.id


# --- refusals -------------------------------------------------------------------------------------


@pytest.mark.parametrize("key", ["range", "distribution"])
def test_refuses_an_entry_without_range_or_distribution(tmp_path, document, key):
    uid = next(e["id"] for e in document["unknowns"] if key in e)
    doc = only(document, uid)
    del doc["unknowns"][0][key]
    message = refusal(tmp_path, doc)
    assert f"unknowns.0 ({uid})" in message
    assert "needs a range [low, high] or a distribution" in message


def test_refuses_an_entry_with_both(tmp_path, document):
    doc = only(document, "bench_zeta")
    doc["unknowns"][0]["range"] = [0.01, 0.2]
    message = refusal(tmp_path, doc)
    assert "(bench_zeta)" in message and "both a range and a distribution" in message


@pytest.mark.parametrize("source", [None, "", "   "])
def test_refuses_an_entry_without_source(tmp_path, document, source):
    doc = only(document, "ripple_wander")
    if source is None:
        del doc["unknowns"][0]["source"]
    else:
        doc["unknowns"][0]["source"] = source
    message = refusal(tmp_path, doc)
    assert "unknowns.0" in message and "(ripple_wander)" in message and "source" in message


@pytest.mark.parametrize(
    "change, says",
    [
        ({"range": [0.2, 0.01]}, "must be [low, high] with low < high"),
        ({"range": [0.1, 0.2]}, "nominal 0.05 is outside its range"),
        ({"nominal": 0.07, "range": [0.01, 0.2]}, "holds 0.05 at twin.stack.zeta, not the nominal"),
        ({"path": "twin.stack.zetta"}, "has no key twin.stack.zetta"),
        ({"path": "protocols/ch6.yaml:experiments.ch6_p1_open.segments.8.hi"}, "has no key"),
        ({"path": "model:stack.zeta"}, "needs `where:`"),
        (
            {"distribution": {"kind": "loguniform", "low": 0.0, "high": 0.2}},
            "needs low > 0",
        ),
    ],
)
def test_refuses_what_no_schema_can_check(tmp_path, document, change, says):
    doc = only(document, "bench_zeta")
    entry = doc["unknowns"][0]
    if "range" in change:
        entry.pop("distribution")
    entry.update(change)
    message = refusal(tmp_path, doc)
    assert "(bench_zeta)" in message and says in message


VARIANT_GROUPS = (
    "amplifier",
    "load path",
    "support mode",
    "rate-dependent hysteresis",
    "frequency-dependent loss",
    "loop delay",
)


def test_the_variants_are_declared_off_and_not_varied_by_the_shipped_design(unknowns):
    """Each variant's keys are declared with a source, their nominal the term off, which a
    manifest leaving them out holds (the schema's default), in groups of their own that the
    shipped envelope design does not vary, so its results do not move."""
    variants = [u for u in unknowns if u.group in VARIANT_GROUPS]
    assert {u.group for u in variants} == set(VARIANT_GROUPS)
    manifest = load_dataset(ROOT / "raw", "pi_p885")
    for u in variants:
        (path,) = u.paths
        # the shipped manifest leaves it out
        assert path.split(".")[1] not in manifest["twin"], u.id
        assert schema_default("dataset.schema.yaml", path.split(".")) == u.nominal, u.id
        assert u.source, u.id
    design = load_yaml(ROOT / "config.yaml")["envelope"]["groups"]
    assert not set(design) & set(VARIANT_GROUPS)


def test_refuses_a_variant_declared_off_elsewhere_than_the_schemas_default(tmp_path, document):
    doc = only(document, "load_path_compliance")
    doc["unknowns"][0]["nominal"] = 1e-8
    message = refusal(tmp_path, doc)
    assert "(load_path_compliance)" in message
    assert "holds 0.0 at twin.load_path.compliance" in message


def test_refuses_an_id_declared_twice(tmp_path, document):
    doc = only(document, "bench_zeta")
    doc["unknowns"].append(copy.deepcopy(doc["unknowns"][0]))
    assert "'bench_zeta' is declared twice" in refusal(tmp_path, doc)


def test_a_protocol_location_names_no_file_outside_the_catalogue(tmp_path, document):
    doc = only(document, "seed_pi_p885")
    doc["unknowns"][0]["path"] = "protocols/../../raw/pi_p885/dataset.yaml:seed"
    assert "does not match" in refusal(tmp_path, doc)


# --- provenance -----------------------------------------------------------------------------------


def test_hash_follows_the_bytes(tmp_path):
    copy_ = tmp_path / "unknowns.yaml"
    copy_.write_bytes(UNKNOWNS.read_bytes())
    first = unknowns_hash(copy_)
    assert first == unknowns_hash(UNKNOWNS) == hashlib.sha256(UNKNOWNS.read_bytes()).hexdigest()
    copy_.write_bytes(UNKNOWNS.read_bytes() + b"# a comment is a different declaration\n")
    assert unknowns_hash(copy_) != first


def _sections_cut_by_a_draw(unknowns):
    """(unknown, drive frequency [Hz]) for every drawn duration of a sine segment that another
    segment follows: where the draw leaves the sine, the next segment starts."""
    for unknown in unknowns:
        for location in unknown.paths:
            match = re.fullmatch(
                r"protocols/(\w+)\.yaml:experiments\.(\w+)\.segments\.(\d+)\.duration", location
            )
            if not match:
                continue
            protocol = load_yaml(ROOT / "workflow" / "protocols" / f"{match[1]}.yaml")
            segments = protocol["experiments"][match[2]]["segments"]
            i = int(match[3])
            if segments[i].get("frequency", 0) > 0 and i + 1 < len(segments):
                yield unknown, float(segments[i]["frequency"])


@settings(max_examples=50, deadline=None)
@given(u=st.floats(0.0, 1.0))
def test_a_drawn_section_ends_a_whole_number_of_its_drive_s_periods(unknowns, u):
    """A sine section cut mid-period would hand the next one a voltage step, which rings the
    stack's resonance: no draw of the envelope may do that (Morris's grid levels nor a Latin
    hypercube's any quantile)."""
    cut = list(_sections_cut_by_a_draw(unknowns))
    assert cut, "the catalogue has drawn sections followed by others (Chapter 7's)"
    for unknown, frequency in cut:
        periods = float(physical(np.array([u]), unknown)[0]) * frequency
        assert periods == pytest.approx(round(periods), abs=1e-9), (unknown.id, frequency, u)
