"""The repository is self-contained: no tracked file names a path outside it, and every link
and citation of the documentation resolves to a file (and section) inside it.

The published numbers live in docs/sources.md and the design in docs/design.md; a file that
cites notes kept elsewhere (a sibling folder, a machine's workspace, a home directory) cannot be
followed from a clone, so it fails here with file:line.
"""

import re
import subprocess

import pytest

from ..helpers import ROOT

# Paths that only exist outside a clone. Each alternative is written so that this file's own
# source does not match it (the sanity test below checks that every one of them does fire).
OUTSIDE = re.compile(
    r"\.\./+shared\b"  # the team's notes next to the repository
    r"|(?<![\w.-])shared/+seeds\b"  # the source texts kept beside them
    r"|\b(?:DESIGN|REFERENCE)\.md\b"  # their file names (the repo has docs/design.md)
    r"|\b\d{3}_[0-9a-f]{16}\.txt\b"  # the extracted source texts
    r"|(?<![\w.~-])/(?:work|home|Users|root|mnt|srv|scratch)/"  # a machine's workspace or home
    r"|(?<![\w])[~]/"  # someone's home directory
    r"|\bfile:/{2}"  # a local URL
)

MD_LINK = re.compile(r"!?\[[^\]]*\]\(([^)\s]+)\)")
DOC_CITATION = re.compile(r"\bdocs/([\w-]+\.md)(?:,\s*\"([^\"]+)\")?")


def tracked_text_files():
    try:
        out = subprocess.run(
            ["git", "ls-files", "-z"], cwd=ROOT, capture_output=True, check=True
        ).stdout
    except (OSError, subprocess.CalledProcessError):
        pytest.skip("not a git checkout: the tracked files are unknown")
    files = {}
    for name in filter(None, out.decode().split("\0")):
        path = ROOT / name
        if not path.is_file():  # deleted in the working tree
            continue
        data = path.read_bytes()
        if b"\0" in data[:8192]:  # binary (pictures, captures)
            continue
        try:
            files[name] = data.decode("utf-8")
        except UnicodeDecodeError:
            continue
    assert files, "git ls-files listed no text file"
    return files


def tracked_names():
    out = subprocess.run(
        ["git", "ls-files", "-z"], cwd=ROOT, capture_output=True, check=True
    ).stdout
    return set(filter(None, out.decode().split("\0")))


def outside_references(text):
    return [m.group(0) for m in OUTSIDE.finditer(text)]


def slug(heading):
    """GitHub's anchor for a markdown heading."""
    return re.sub(r"[^\w\- ]", "", heading.strip().lower()).replace(" ", "-")


def headings(text):
    return [line.lstrip("#").strip() for line in text.splitlines() if re.match(r"#{1,6} ", line)]


def test_the_pattern_catches_outside_references_and_spares_inside_ones():
    notes = "REFERENCE" + ".md"
    for bad in [
        "see ../" + f"shared/{notes}",
        f"({notes}, known inconsistencies)",
        "DESIGN" + ".md",
        "../../" + "shared/" + "seeds/README.md",
        "/work" + "/shared/x",
        "/home" + "/me/notes.md",
        "~" + "/notes.md",
        "000_a2a510d427dc5c56" + ".txt",
        "file:" + "//tmp/x",
    ]:
        assert outside_references(bad), bad
    for good in [
        "docs/design.md",
        "[design](design.md#the-digital-twin)",
        "docs/sources.md",
        "../scripts/simulate.py",
        "/tmp/before.csv",
        "/var/tmp/selfsense-slurm",
        "raw/pi_p885/dataset.yaml",
        "dataset name '../pi_p885'",
        "benchmarks/README.md",
        "results/data/x.csv",
        "https://json-schema.org/draft/2020-12/schema",
    ]:
        assert not outside_references(good), good


def test_no_tracked_file_names_a_path_outside_the_repository():
    files = tracked_text_files()
    assert (
        "README.md" in files
        and "workflow/scorecard.yaml" in files
        and "src/selfsense/io/capture.py" in files
    )
    found = [
        f"{name}:{n}: {hit}"
        for name, text in files.items()
        for n, line in enumerate(text.splitlines(), 1)
        for hit in outside_references(line)
    ]
    assert not found, "names a path outside the repository:\n" + "\n".join(found)


def test_every_relative_link_of_the_readme_and_docs_resolves_inside_the_repository():
    files = tracked_text_files()
    tracked = tracked_names()
    pages = ["README.md"] + sorted(n for n in files if n.startswith("docs/") and n.endswith(".md"))
    assert len(pages) > 5, pages
    broken, checked = [], 0
    for page in pages:
        base = (ROOT / page).parent
        for n, line in enumerate(files[page].splitlines(), 1):
            for target in MD_LINK.findall(line):
                if re.match(r"[a-z]+:", target):  # http(s), mailto: not a file
                    continue
                checked += 1
                path, _, anchor = target.partition("#")
                file = (base / path).resolve() if path else (ROOT / page).resolve()
                try:
                    rel = file.relative_to(ROOT.resolve()).as_posix()
                except ValueError:
                    broken.append(f"{page}:{n}: {target} leaves the repository")
                    continue
                if rel not in tracked:
                    broken.append(f"{page}:{n}: {target} is not a file of the repository")
                elif anchor and anchor not in {slug(h) for h in headings(file.read_text())}:
                    broken.append(f"{page}:{n}: {target} has no heading #{anchor}")
    assert checked > 20, checked
    assert not broken, "\n".join(broken)


def test_every_citation_of_a_docs_page_names_a_page_and_section_that_exist():
    files = tracked_text_files()
    broken, checked = [], 0
    for name, text in files.items():
        for n, line in enumerate(text.splitlines(), 1):
            for page, section in DOC_CITATION.findall(line):
                checked += 1
                target = f"docs/{page}"
                if target not in files:
                    broken.append(f"{name}:{n}: {target} does not exist")
                elif section and not any(
                    h.lower().startswith(section.lower()) for h in headings(files[target])
                ):
                    broken.append(f'{name}:{n}: {target} has no section "{section}"')
    assert checked >= 5, checked
    assert not broken, "\n".join(broken)
