"""The envelope's config is bounded where it is read, and its members cost a run nothing unless
it asks for them: Snakemake started on the repository, parsing the workflow only (a refusal, or
--list-target-rules), so each run takes the seconds of a parse."""

import resource

import yaml

from ..helpers import ROOT, SMOKE_CONFIG, error_line, run_snakemake


def envelope_config(tmp_path, **envelope):
    """The smoke config's files with ``envelope`` keys changed, as run_snakemake's arguments."""
    path = tmp_path / "envelope.yaml"
    path.write_text(yaml.safe_dump({"envelope": envelope}))
    return ["--configfile", str(ROOT / SMOKE_CONFIG), str(path)]


def cpu_of_children() -> float:
    """The CPU seconds (user and system) of this process's finished children."""
    used = resource.getrusage(resource.RUSAGE_CHILDREN)
    return used.ru_utime + used.ru_stime


def test_ten_thousand_members_are_refused_at_once_naming_the_key(tmp_path):
    # CPU, not wall time: seven sessions share these two cores, and Snakemake's own start alone
    # takes 1.2 s of CPU and up to 3 s of wall; the refusal comes before the workflow's first rule
    before = cpu_of_children()
    run = run_snakemake(ROOT, "-n", *envelope_config(tmp_path, members=10_000), config=None)
    assert cpu_of_children() - before < 5.0
    assert run.returncode != 0
    assert "key envelope.members: 10000 is greater than the maximum of 500" in error_line(
        run, "envelope.members"
    )


def test_a_run_that_asks_for_no_envelope_target_draws_no_member(tmp_path):
    """A design its groups make impossible to draw: the default run's parse never reads it (no
    member drawn, no unknown loaded), the envelope's refuses it in one line."""
    args = envelope_config(tmp_path, members=500, spread=0, groups=["no such group"])
    listed = run_snakemake(ROOT, "--list-target-rules", *args, config=None)
    assert listed.returncode == 0, listed.stderr[-2000:]
    drawn = run_snakemake(ROOT, "-n", "envelope", *args, config=None)
    assert drawn.returncode != 0
    assert "'no such group' is no group" in error_line(drawn, "key envelope.groups")


def test_a_chapter_no_row_has_is_refused(tmp_path):
    args = envelope_config(tmp_path, chapters=["99"])
    run = run_snakemake(ROOT, "--list-target-rules", *args, config=None)
    assert run.returncode != 0
    assert "'99' is no chapter of the scorecard's emergent rows" in error_line(
        run, "key envelope.chapters"
    )
