"""A member of the envelope or the validation run in one process: the rules' own jobs, in order.

Through the rules a member is some 40–70 jobs, each a fresh interpreter that imports the library
before its work (about a second of CPU a job, half a member's). Here the member is one job: the
workflow's DAG for the member's outputs (Snakemake's own, built once for a batch of members by
:func:`member_steps`) becomes a list of :class:`Step`, and :func:`run_steps` calls each rule's
script's ``main`` in this process, through :func:`selfsense.io.provenance.run` as Snakemake
would, with the same inputs, outputs and params. The numbers are therefore the rules' numbers by
construction; ``tests/workflow/test_member.py`` holds one member's scorecard from here equal, value
for value, to its scorecard through the rules.

What a step writes goes under a scratch folder in the temporary directory, not under raw/ and
results/: the member's dataset is not materialised, and a reviewer who audits a
member runs the rules on it like on any dataset (``snakemake results/<member>/scorecard.csv``).
A capture is written as the capture contract holds it (packed int16 with its scale, the same
CaptureWriter), so what a step reads back is what a reader of the rules' file would get, and is
deleted after the last step that reads it; the steps run in an order that reads each capture
before the next is simulated (:func:`lean_order`), so the scratch holds a few captures at once.
"""

from __future__ import annotations

import importlib.util
import logging
import os
import resource
import shutil
import sys
import tempfile
import time
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from contextlib import chdir, contextmanager
from dataclasses import dataclass
from functools import cache
from pathlib import Path
from typing import Any

from selfsense.io.capture import scratch_captures
from selfsense.io.provenance import atomic_path, code_version, commit, one_line_reason, run

LOG = logging.getLogger("selfsense")
#: the start of a member's scratch folder's name, in the temporary directory
SCRATCH_PREFIX = "selfsense-member"


@dataclass(frozen=True)
class Step:
    """One job of the workflow's DAG as its script sees it: the rule, its script file, and its
    named inputs, outputs and params (a value a path, a list of paths, or a param's value)."""

    rule: str
    script: str
    input: tuple[tuple[str, Any], ...]
    output: tuple[tuple[str, Any], ...]
    params: tuple[tuple[str, Any], ...]
    log: tuple[str, ...]

    def files(self, kind: str) -> list[str]:
        return list(_flat(dict(getattr(self, kind)).values()))

    def record(self) -> dict[str, Any]:
        """The step as JSON holds it (a step table a rule's params can carry)."""
        return {
            "rule": self.rule,
            "script": self.script,
            **{k: [list(p) for p in getattr(self, k)] for k in ("input", "output", "params")},
            "log": list(self.log),
        }

    @classmethod
    def from_record(cls, record: Mapping[str, Any]) -> Step:
        pairs = {k: tuple((n, v) for n, v in record[k]) for k in ("input", "output", "params")}
        return cls(record["rule"], record["script"], log=tuple(record["log"]), **pairs)


def _flat(values: Iterable[Any]) -> Iterator[str]:
    for value in values:
        if isinstance(value, (list, tuple)):
            yield from (str(v) for v in value)
        else:
            yield str(value)


class _Named:
    """The part of Snakemake's Namedlist that :func:`~selfsense.io.provenance.run` reads."""

    def __init__(self, pairs: Iterable[tuple[str, Any]]):
        self._pairs = list(pairs)
        self._files = list(_flat(v for _, v in self._pairs))

    def items(self) -> list[tuple[str, Any]]:
        return list(self._pairs)

    def get(self, name: str, default: Any = None) -> Any:
        return dict(self._pairs).get(name, default)

    def __iter__(self) -> Iterator[str]:
        return iter(self._files)

    def __len__(self) -> int:
        return len(self._files)

    def __getitem__(self, index: int) -> str:
        return self._files[index]


@dataclass(frozen=True)
class _Job:
    """What ``run`` reads of the ``snakemake`` object a script is given."""

    rule: str
    input: _Named
    output: _Named
    params: _Named
    log: _Named


def member_steps(
    snakefile: str | Path,
    groups: Mapping[str, Sequence[str]],
    config: Mapping[str, Any],
    given: Iterable[str] = (),
) -> dict[str, list[Step]]:
    """Per group (a member: the files it must make), the jobs Snakemake runs to make them from
    nothing (``--forceall``), in an order it could run them, as steps. One DAG holds every
    group's targets; a group's steps are its targets' jobs and all they depend on. Jobs whose
    outputs are all in ``given`` (the members' manifests, inputs of the jobs that run the
    members) are left out. The workflow is parsed with ``config`` (the calling run's, command-line
    values included) in the current directory, with the targets as its command line, which is
    where the workflow looks for whether members are asked (common.smk)."""
    from snakemake.api import SnakemakeApi
    from snakemake.settings.types import (
        ConfigSettings,
        DAGSettings,
        OutputSettings,
        ResourceSettings,
    )

    given = set(map(str, given))
    targets = sorted({t for files in groups.values() for t in files})
    argv, sys.argv = sys.argv, ["snakemake", *targets]
    try:
        with SnakemakeApi(OutputSettings(quiet={"all"})) as api:
            workflow_api = api.workflow(
                resource_settings=ResourceSettings(cores=1),
                config_settings=ConfigSettings(config=dict(config)),
                snakefile=Path(snakefile),
                workdir=Path.cwd(),
            )
            dag_api = workflow_api.dag(DAGSettings(targets=set(targets), forceall=True))
            workflow = dag_api.workflow_api._workflow
            workflow._prepare_dag(
                forceall=True, ignore_incomplete=True, lock_warn_only=True, nolock=True
            )
            workflow._build_dag()
            dag = workflow.dag
            order = [job for level in dag.toposorted() for job in _sorted(level)]
            kept = [j for j in order if not {str(f) for f in j.output} <= given]
            steps = {}
            for name, files in groups.items():
                needed = _ancestry(dag, files, order)
                steps[name] = [_step(j) for j in kept if j in needed]
            return steps
    finally:
        sys.argv = argv


def _sorted(level: Iterable[Any]) -> list[Any]:
    return sorted(level, key=lambda j: (j.rule.name, [str(f) for f in j.output]))


def _ancestry(dag: Any, files: Sequence[str], order: Sequence[Any]) -> set[Any]:
    """The jobs that make ``files`` and every job they depend on."""
    wanted = set(map(str, files))
    todo = [j for j in order if wanted & {str(f) for f in j.output}]
    seen: set[Any] = set()
    while todo:
        job = todo.pop()
        if job not in seen:
            seen.add(job)
            todo.extend(dag.dependencies[job])
    return seen


def _step(job: Any) -> Step:
    if job.rule.script is None:
        raise ValueError(f"rule {job.rule.name}: a member's step must be a script")
    return Step(
        job.rule.name,
        str((Path(job.rule.basedir) / job.rule.script).resolve()),
        _pairs(job.input),
        _pairs(job.output),
        _pairs(job.params),
        tuple(str(f) for f in job.log),
    )


def _pairs(named: Any) -> tuple[tuple[str, Any], ...]:
    """A Namedlist's items as plain data: its files (str subclasses) and paths as str."""

    def plain(value: Any) -> Any:
        if isinstance(value, (list, tuple)):
            return [plain(v) for v in value]
        if isinstance(value, dict):
            return {k: plain(v) for k, v in value.items()}
        return str(value) if isinstance(value, (str, os.PathLike)) else value

    return tuple((name, plain(value)) for name, value in named.items())


@cache
def _main(script: str) -> Callable[..., Any]:
    """A rule's script's ``main``, its module loaded once a process (not run: it runs its rule
    only when Snakemake gives it ``snakemake``)."""
    spec = importlib.util.spec_from_file_location(f"_step_{Path(script).stem}", script)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.main


@contextmanager
def scratch_folder(prefix: str) -> Iterator[Path]:
    """A folder for one member's files in the temporary directory (``TMPDIR``), removed afterwards
    whatever happens; the folders of members whose process is gone (killed before they could
    remove theirs) are removed first."""
    base = Path(tempfile.gettempdir())
    for stale in base.glob(f"{SCRATCH_PREFIX}.*"):
        pid = stale.name.split(".")[1]
        if pid.isdigit() and not _alive(int(pid)):
            shutil.rmtree(stale, ignore_errors=True)
    folder = Path(tempfile.mkdtemp(prefix=f"{SCRATCH_PREFIX}.{os.getpid()}.{prefix}.", dir=base))
    try:
        yield folder
    finally:
        shutil.rmtree(folder, ignore_errors=True)


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # another user's: alive
        return True
    return True


def lean_order(steps: Sequence[Step]) -> list[Step]:
    """The steps in an order that keeps few captures at once: as soon as a step's inputs are made
    it runs before any step that reads only sources (a simulation), so each capture is read by its
    steps and deleted before the next is simulated; of the simulations ready, the one more steps
    wait on runs first (Chapter 4's captures, whose identification every Chapter 7 capture's
    reader needs, before a Chapter 7 capture that would wait for it). Every step still comes after
    those that make its inputs (Kahn's algorithm, ties in the given order)."""
    maker = {path: i for i, step in enumerate(steps) for path in step.files("output")}
    needs = [{maker[p] for p in step.files("input") if p in maker} for step in steps]
    reads_made = [bool(n) for n in needs]
    readers: list[set[int]] = [set() for _ in steps]
    for i, made_by in enumerate(needs):
        for j in made_by:
            readers[j].add(i)
    waiting = [len(_downstream(i, readers)) for i in range(len(steps))]
    done: set[int] = set()
    order: list[Step] = []
    while len(order) < len(steps):
        ready = [i for i in range(len(steps)) if i not in done and needs[i] <= done]
        if not ready:
            raise ValueError("the steps' inputs and outputs form a cycle")
        i = min(ready, key=lambda k: (not reads_made[k], 0 if reads_made[k] else -waiting[k], k))
        done.add(i)
        order.append(steps[i])
    return order


def _downstream(start: int, readers: Sequence[set[int]]) -> set[int]:
    """The steps that read ``start``'s outputs, and those that read theirs, on."""
    seen: set[int] = set()
    todo = list(readers[start])
    while todo:
        i = todo.pop()
        if i not in seen:
            seen.add(i)
            todo.extend(readers[i])
    return seen


def run_steps(steps: Sequence[Step], scratch: Path, keep: Iterable[str] = ()) -> dict[str, Path]:
    """Run the steps in order in this process, in ``scratch`` as the working directory: every
    input no step makes is linked there from the checkout under its own path, so each step's
    paths, params included, mean what they mean to the rules. A file a step makes is deleted
    after the last step that reads it, unless it is in ``keep``; returns where each of ``keep``
    is. A step that fails stops the member with its rule named; the scratch is the caller's to
    remove."""
    keep = set(map(str, keep))
    steps = lean_order(steps)
    made = {path for step in steps for path in step.files("output")}
    last_read = {path: i for i, step in enumerate(steps) for path in step.files("input")}
    done_after: dict[int, list[str]] = {}  # per step, the made files no later step reads
    for path, last in last_read.items():
        if path in made and path not in keep:
            done_after.setdefault(last, []).append(path)
    checkout = Path.cwd()
    for path in sorted(_sources(set(last_read) - made, made)):
        link = scratch / path
        if not link.exists():
            link.parent.mkdir(parents=True, exist_ok=True)
            link.symlink_to(checkout / path)
    for step in steps:
        for path in step.files("output") + list(step.log):
            (scratch / path).parent.mkdir(parents=True, exist_ok=True)
    code_version(), commit()  # of the checkout, before the working directory moves
    with chdir(scratch), scratch_captures():
        for i, step in enumerate(steps):
            job = _Job(
                step.rule,
                _Named(step.input),
                _Named(step.output),
                _Named(step.params),
                _Named(("log", p) for p in step.log),
            )
            began = time.perf_counter()
            with _step_logging(step):
                run(_main(step.script), job)
            LOG.info("%s: %.2f s", ", ".join(step.files("output")), time.perf_counter() - began)
            for path in done_after.get(i, ()):
                Path(path).unlink(missing_ok=True)
    return {path: scratch / path for path in keep}


class StepFailed(RuntimeError):
    """A member's step raised: the message names its rule, its outputs and the reason."""


@contextmanager
def _step_logging(step: Step) -> Iterator[None]:
    """A step's script logs to its own log file (script_logging); afterwards the member's log
    gets it, and the member's handlers and excepthook are back. A step that fails stops the
    member in one line naming its rule and its outputs."""
    handlers, hook = list(LOG.handlers), sys.excepthook
    failed = None
    try:
        yield
    except Exception as err:
        failed = err
    finally:
        LOG.handlers[:], sys.excepthook = handlers, hook
        for path in step.log:
            if Path(path).is_file():
                LOG.info("rule %s:\n%s", step.rule, Path(path).read_text().rstrip())
    if failed is not None:
        outputs = ", ".join(step.files("output"))
        raise StepFailed(f"rule {step.rule} ({outputs}): {one_line_reason(failed)}") from failed


def run_member(
    steps: Sequence[Step],
    keep: Mapping[str, str | Path],
    name: str,
    failure: str | Path | None = None,
) -> str:
    """Run a member's steps in a scratch folder (:func:`run_steps`) and put the files of
    ``keep`` ({path in the workflow: where it goes}) where they go; the scratch is gone
    afterwards, and a member that fails leaves none of them. A failing step raises
    :class:`StepFailed`, or, with ``failure`` (a validation member: a bench whose analysis
    fails is a result of the ensemble, not an error of the run), writes its one line there and
    returns it ("" when every step ran)."""
    began = time.perf_counter()
    with scratch_folder(name.replace("~", "_")) as scratch:
        try:
            where = run_steps(steps, scratch, keep)
        except StepFailed as err:
            if failure is None:
                raise
            LOG.warning("member %s failed: %s", name, err)
            with atomic_path(failure) as tmp:
                Path(tmp).write_text(f"{err}\n", encoding="utf-8")
            return str(err)
        for path, destination in keep.items():
            with atomic_path(destination) as tmp:
                shutil.copyfile(where[path], tmp)
    usage = resource.getrusage(resource.RUSAGE_SELF)
    LOG.info(
        "member %s: %d steps in %.1f s; the process's CPU %.1f s, peak memory %.0f MB",
        name,
        len(steps),
        time.perf_counter() - began,
        usage.ru_utime + usage.ru_stime,
        usage.ru_maxrss / 1024,
    )
    return ""


def _sources(inputs: Iterable[str], made: Iterable[str]) -> set[str]:
    """What to link for ``inputs``: for each, its highest folder that holds nothing a step makes
    (a script may read beside its input: the catalogue's other protocols), else the file."""
    holding = {parent for path in made for parent in Path(path).parents}
    linked = set()
    for path in map(Path, inputs):
        free = [p for p in path.parents if p != Path(".") and p not in holding]
        linked.add(str(free[-1] if free else path))
    return linked
