# selfsense: Islam 2013 (piezo stack self-sensing) and Ronkanen 2002 (bender current control).
# `snakemake --cores 2` makes every capture and result; see README.md. Helpers, the stage plan and
# every name the rule files share live in workflow/rules/common.smk; each other .smk holds one
# stage's rules and the *_OUTPUTS list of what they make; settings are config.yaml's
# (docs/configuration.md).
from snakemake.utils import min_version

from selfsense.io.audit import check_inputs_unchanged

min_version("9.0")


configfile: "config.yaml"


report: "workflow/report/workflow.rst"


include: "workflow/rules/common.smk"
include: "workflow/rules/acquire.smk"
include: "workflow/rules/ripple.smk"
include: "workflow/rules/identify.smk"
include: "workflow/rules/gamma.smk"
include: "workflow/rules/observer.smk"
include: "workflow/rules/control.smk"
include: "workflow/rules/thermal.smk"
include: "workflow/rules/powerloss.smk"
include: "workflow/rules/characterise.smk"
include: "workflow/rules/verify.smk"
include: "workflow/rules/stages.smk"
include: "workflow/rules/report.smk"
include: "workflow/rules/twin.smk"
include: "workflow/rules/envelope.smk"
include: "workflow/rules/validation.smk"
include: "workflow/rules/members.smk"


# A measured capture or manifest replaced by other bytes with an older mtime (cp -p, rsync -t,
# tar x) would give "Nothing to be done": stop with one line naming it. Here, not in onstart:
# onstart runs neither in a dry run nor when there is nothing to do (docs/reliability.md).
check_inputs_unchanged(MEASURED)


rule all:
    default_target: True
    input:
        # the run's own datasets: the envelope's members only for `snakemake envelope`
        nominal(
            ACQUIRE_OUTPUTS,
            RIPPLE_OUTPUTS,
            IDENTIFY_OUTPUTS,
            GAMMA_OUTPUTS,
            OBSERVER_OUTPUTS,
            CONTROL_OUTPUTS,
            THERMAL_OUTPUTS,
            POWERLOSS_OUTPUTS,
            CHARACTERISE_OUTPUTS,
            VERIFY_OUTPUTS,
            STAGE_PLAN_OUTPUTS,
            REPORT_OUTPUTS,
            TWIN_OUTPUTS,
        ),
