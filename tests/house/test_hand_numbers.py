"""No result is typed into the README or docs/ by hand: a number with a unit there is written by
scripts/update_docs.py (its generated blocks), or it is not a result.

A *number with a unit* is a decimal number followed by one of :data:`UNITS` (time, memory, share,
frequency, length, electrical, temperature, angle). It is not a result, and may be typed, when:

- it is a **setting or a published value**: the same number is in a settings file (config.yaml,
  the smoke config, the protocols, the manifests, workflow/unknowns.yaml's ranges, the twin's
  calibration targets), in the scorecard's registry (every published number and its band) or in
  a table of docs/sources.md (the sources' numbers) — compared as numbers, with the unit's prefix
  applied or not, since a YAML holds a frequency in Hz that a page quotes in kHz;
- it is a **measured figure of docs/performance.md**, the page of the machine's figures, in a
  table row beside how it is measured (a table with a "measured by" column), never in its prose;
- it is a **constant of a method's description** that an equation gives from the settings, named
  in :data:`DERIVED` with the reason.

Everything is looked at outside fenced and indented code, inline code and the generated blocks.
docs/sources.md (the published numbers) and docs/configuration.md (generated whole from the
config schema, tests/house/test_configuration.py) are not looked at.
"""

import math
import re

from ..helpers import ROOT

UNITS = (
    "ns|µs|ms|s|min|h|kB|KB|MB|GB|MiB|GiB|%|Hz|kHz|MHz|nm|µm|mm|N/µm|mV|kV|V|nA|µA|mA|A|mW|W"
    "|kΩ|MΩ|Ω|°C|°|pF|nF|µF|F"
)
NUMBER_WITH_UNIT = re.compile(
    r"(?<![\w.`/−-])(\d+(?:\.\d+)?)[ \u00a0\u202f]?(" + UNITS + r")(?![\w/²³])"
)
PREFIX = {"n": 1e-9, "µ": 1e-6, "m": 1e-3, "k": 1e3, "M": 1e6, "G": 1e9}
SCALE = {"%": 1e-2, "min": 60.0, "h": 3600.0}

PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
NOT_LOOKED_AT = {"sources.md", "configuration.md"}
PERFORMANCE = "docs/performance.md"

SETTINGS = [
    ROOT / "config.yaml",
    ROOT / "tests" / "config" / "smoke.yaml",
    *sorted((ROOT / "workflow" / "protocols").glob("*.yaml")),
    *sorted((ROOT / "raw").glob("*/dataset.yaml")),
    ROOT / "workflow" / "unknowns.yaml",
    ROOT / "workflow" / "twin_calibration.yaml",
    ROOT / "workflow" / "scorecard.yaml",
]

#: (page, the number with its unit as the page writes it): why it is a method's constant
DERIVED = {
    (
        "docs/twin.md",
        "0.29 mA",
    ): "the ADC's quantisation, one code over √12 (Eq of the uniform error)",
    ("docs/twin.md", "0.087 µm"): "the same for the laser channel",
    (
        "docs/twin.md",
        "66.0°",
    ): "the manifest's ripple phase, in degrees as the twin's table prints it",
    ("docs/twin.md", "110 s"): "τ from the manifest's k_T by Eq 7.5",
    ("docs/twin.md", "109.9 s"): "the same, to a tenth",
    (
        "docs/twin.md",
        "0.65 W",
    ): "the loss power a 37 K rise needs at the manifest's k_T (Eq 7.5–7.6)",
    ("docs/twin.md", "12.3 V"): "the loop width that power needs (P = w·U·f), an energy balance",
    ("docs/twin.md", "12.3 %"): "the same width as a share of the voltage",
    ("docs/twin.md", "11.7 %"): "the thesis's 11.72 % (Table 6.2), rounded",
    ("docs/deviations.md", "11.7 %"): "the thesis's 11.72 % (Table 6.2), rounded",
    ("docs/design.md", "11.7 %"): "the thesis's 11.72 % (Table 6.2), rounded",
    ("docs/deviations.md", "29 mm"): "the L_P that the thesis's printed d33 implies (Eq 4.24)",
}

GENERATED = re.compile(r"<!-- [\w-]+:[\w-]+ (begin|end)\b")


def allowed_values() -> set[float]:
    numbers = re.compile(r"(?<![\w.])-?\d+(?:\.\d+)?(?:[eE][-+]?\d+)?")
    texts = [p.read_text(encoding="utf-8") for p in SETTINGS]
    sources = (ROOT / "docs" / "sources.md").read_text(encoding="utf-8")
    texts += [line for line in sources.splitlines() if line.startswith("|")]
    return {float(m) for text in texts for m in numbers.findall(text.replace("−", "-"))}


def is_setting(number: str, unit: str, values: set[float]) -> bool:
    value = float(number)
    candidates = {value, value * SCALE.get(unit, 1.0)}
    if len(unit) > 1 and unit[0] in PREFIX and unit not in SCALE:
        candidates.add(value * PREFIX[unit[0]])
    return any(math.isclose(c, v, rel_tol=1e-9) for c in candidates for v in values)


def prose(text: str):
    """(line number, line, whether in a table row, the header of its table) of the text outside
    code and generated blocks, inline code taken out."""
    generated = fenced = False
    header = None
    for number, line in enumerate(text.splitlines(), 1):
        if found := GENERATED.match(line):
            generated = found[1] == "begin"
            continue
        if line.startswith("```"):
            fenced = not fenced
            continue
        indented = line.startswith("    ") and not re.match(r"\s+([-*]|\d+\.) ", line)
        if generated or fenced or indented:
            continue
        row = line.startswith("|")
        if row and header is None:
            header = line
        elif not row:
            header = None
        yield number, re.sub(r"`[^`]*`", "", line), row, header


def typed_results(name: str, text: str, values: set[float]) -> list[str]:
    found = []
    for number, line, row, header in prose(text):
        for match in NUMBER_WITH_UNIT.finditer(line):
            if is_setting(match[1], match[2], values) or (name, match[0]) in DERIVED:
                continue
            if name == PERFORMANCE and row and "measured by" in (header or ""):
                continue
            found.append(f"{name}:{number}: {match[0]}")
    return found


def test_no_page_has_a_result_typed_by_hand():
    values = allowed_values()
    found = [
        hit
        for page in PAGES
        if page.name not in NOT_LOOKED_AT
        for hit in typed_results(
            str(page.relative_to(ROOT)), page.read_text(encoding="utf-8"), values
        )
    ]
    assert not found, (
        "a result typed by hand (generate it with scripts/update_docs.py, or see this test's"
        " docstring for what may be typed):\n" + "\n".join(found)
    )


def test_the_rule_tells_results_from_settings_and_published_values():
    values = {100000.0, 1.38, 60.0}
    page = "\n".join(
        [
            "The ripple at 100 kHz, published 1.38 µm, a 60 s hold.",  # settings and published
            "The twin gives 1.16 µm in 20.3 s.",  # two results
            "Run `snakemake --cores 2` for 12.5 s.",  # inline code; 12.5 s is a result
            "    python run.py --seconds 20 s",  # indented code
            "<!-- scorecard:counts begin (scripts/update_docs.py writes this block) -->",
            "| 3.14 µm |",
            "<!-- scorecard:counts end -->",
            "| part | figure | measured by |",
            "|---|---|---|",
            "| a job | 2.0 s | B |",
        ]
    )
    assert typed_results("docs/twin.md", page, values) == [
        "docs/twin.md:2: 1.16 µm",
        "docs/twin.md:2: 20.3 s",
        "docs/twin.md:3: 12.5 s",
        "docs/twin.md:10: 2.0 s",
    ]
    # on the performance page a measured figure sits in its table, not in the prose
    assert typed_results(PERFORMANCE, page, values) == [
        "docs/performance.md:2: 1.16 µm",
        "docs/performance.md:2: 20.3 s",
        "docs/performance.md:3: 12.5 s",
    ]
