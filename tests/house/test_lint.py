"""scripts/lint_workflow.py: `snakemake --lint` fails CI on every lint but the declined ones."""

from ..helpers import ROOT, load_module

CONDA = "Specify a conda environment or container for each rule."

LINTED = f"""Using workflow specific profile profiles/default for setting default arguments.
Lints for snakefile /repo/workflow/rules/common.smk:
    * Mixed rules and functions in same snakefile.:
      Small one-liner functions used only once should be defined as lambda
      expressions.

Lints for rule simulate (line 9, /repo/workflow/rules/acquire.smk):
    * {CONDA}:
      This way, the used software for each specific step is documented.
    * Param raw_dir is a prefix of input or output file but hardcoded:
      If this is meant to represent a file path prefix, it will fail.
"""


def lint_workflow():
    return load_module(ROOT / "scripts" / "lint_workflow.py")


def test_every_lint_is_read_with_what_it_is_about():
    assert lint_workflow().lints(LINTED) == [
        (
            "snakefile /repo/workflow/rules/common.smk",
            "Mixed rules and functions in same snakefile.",
        ),
        ("rule simulate (line 9, /repo/workflow/rules/acquire.smk)", CONDA),
        (
            "rule simulate (line 9, /repo/workflow/rules/acquire.smk)",
            "Param raw_dir is a prefix of input or output file but hardcoded",
        ),
    ]


def test_only_the_declined_lints_pass():
    module = lint_workflow()
    assert set(module.DECLINED) == {CONDA}
    only_declined = "\n".join(LINTED.splitlines()[:1] + LINTED.splitlines()[6:9]) + "\n"
    assert module.verdict(1, only_declined) == ([], None)
    left, failed = module.verdict(1, LINTED)
    assert failed is None and [title for _, title in left] == [
        "Mixed rules and functions in same snakefile.",
        "Param raw_dir is a prefix of input or output file but hardcoded",
    ]
    assert module.verdict(0, "Congratulations, your workflow is in a good condition!\n") == (
        [],
        None,
    )


def test_a_workflow_that_does_not_parse_fails_the_check():
    left, failed = lint_workflow().verdict(1, 'KeyError in file "Snakefile", line 3:\n')
    assert left == [] and "failed without a lint" in failed
