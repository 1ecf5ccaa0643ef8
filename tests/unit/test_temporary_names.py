"""Temporary names: unique across hosts and PID namespaces, and reaped by age alone, so that a
writer on another host or in another container never loses its temporary to this one."""

import os
import re
import subprocess
import sys
import time

import pandas as pd
import pytest

from selfsense.io import provenance
from selfsense.io.provenance import (
    REAP_AGE_S,
    atomic_path,
    reap_stale_temporaries,
    temporary_path,
    write_table,
)

NAME = re.compile(r"c\.nc\.(?P<host>[A-Za-z0-9-]{1,32})\.(?P<random>[0-9a-f]{16})\.part")
HIDDEN = re.compile(r"\.t\.(?P<host>[A-Za-z0-9-]{1,32})\.(?P<random>[0-9a-f]{16})\.part\.csv")


def as_host(monkeypatch, name, pid):
    """This process as a writer on host ``name`` with PID ``pid`` (another node, a container)."""
    monkeypatch.setattr(provenance.socket, "gethostname", lambda: name)
    monkeypatch.setattr(provenance.os, "getpid", lambda: pid)


def make(tmp, age_s=0.0):
    """Create a writer's temporary, last modified ``age_s`` ago."""
    tmp.write_bytes(b"half-written")
    if age_s:
        then = time.time() - age_s
        os.utime(tmp, (then, then))
    return tmp


def dead_pid():
    """A PID that no process of this namespace has now."""
    child = subprocess.run(
        [sys.executable, "-c", "import os; print(os.getpid())"],
        text=True,
        capture_output=True,
        check=True,
    )
    return int(child.stdout)


def test_names_carry_the_host_and_64_random_bits_and_keep_the_part_suffix(tmp_path, monkeypatch):
    as_host(monkeypatch, "node17.cluster.example.org", 4242)
    name = temporary_path(tmp_path / "c.nc").name
    assert NAME.fullmatch(name) and NAME.fullmatch(name)["host"] == "node17", name
    hidden = temporary_path(tmp_path / "t.csv", hidden=True).name
    assert HIDDEN.fullmatch(hidden) and hidden.startswith("."), hidden
    # the suffix the writers and tests/helpers.leftovers know
    assert name.endswith(".part") and hidden.startswith(".")
    monkeypatch.setattr(provenance.socket, "gethostname", lambda: "ünïcode host/with:odd chars")
    assert NAME.fullmatch(temporary_path(tmp_path / "c.nc").name)
    monkeypatch.setattr(provenance.socket, "gethostname", lambda: "")
    assert NAME.fullmatch(temporary_path(tmp_path / "c.nc").name)


def test_names_never_collide_in_one_process_nor_across_containers(tmp_path, monkeypatch):
    names = set()
    for host in ("container", "container", "other"):  # two containers named alike, both PID 1
        as_host(monkeypatch, host, 1)
        names |= {temporary_path(tmp_path / "c.nc").name for _ in range(1000)}
    assert len(names) == 3000


def test_writers_on_other_hosts_never_reap_each_others_fresh_temporaries(tmp_path, monkeypatch):
    out = tmp_path / "c.nc"
    as_host(monkeypatch, "node-a", 7)
    a = make(temporary_path(out))
    a_hidden = make(temporary_path(out, hidden=True))
    # node-b, where PID 7 does not run (nor anything: another PID namespace)
    as_host(monkeypatch, "node-b", 7)
    b = make(temporary_path(out))
    with atomic_path(out) as tmp:
        tmp.write_bytes(b"b's output")
    as_host(monkeypatch, "node-a", 9)
    temporary_path(out)
    temporary_path(out, hidden=True)
    assert a.exists() and a_hidden.exists() and b.exists()
    assert out.read_bytes() == b"b's output"


def test_a_dead_pid_in_a_name_does_not_make_a_fresh_temporary_stale(tmp_path):
    """Names of earlier versions carried the writer's PID, and a PID not running here was taken
    as a dead writer: in another PID namespace it is a live one."""
    out = tmp_path / "c.nc"
    legacy = make(tmp_path / f"c.nc.{dead_pid()}-0123abcd.part")
    legacy_hidden = make(tmp_path / f".c.{dead_pid()}-0123abcd.part.nc")
    temporary_path(out)
    temporary_path(out, hidden=True)
    assert legacy.exists() and legacy_hidden.exists()


def test_a_temporary_not_modified_for_the_reap_age_is_removed_whoever_wrote_it(tmp_path):
    out = tmp_path / "c.nc"
    old = [
        make(tmp_path / "c.nc.node-a.0123456789abcdef.part", REAP_AGE_S + 60),
        make(tmp_path / ".c.node-b.fedcba9876543210.part.nc", REAP_AGE_S + 60),
        make(tmp_path / "c.nc.12345-0123abcd.part", REAP_AGE_S + 60),  # an earlier version's
    ]
    young = make(tmp_path / "c.nc.node-a.1111111111111111.part", REAP_AGE_S - 60)
    temporary_path(out)
    temporary_path(out, hidden=True)
    assert not any(p.exists() for p in old)
    assert young.exists()


def test_the_reaper_removes_only_temporaries_of_that_output(tmp_path):
    ancient = REAP_AGE_S * 10
    others = [
        make(tmp_path / "c.nc", ancient),  # the output itself
        make(tmp_path / "c.nc.part", ancient),  # not a temporary's name
        make(tmp_path / "c.nc.my notes.part", ancient),
        make(tmp_path / "c.nc.x.node-a.0123456789abcdef.part", ancient),  # output c.nc.x's
        make(tmp_path / ".c.x.node-a.0123456789abcdef.part.nc", ancient),  # output c.x.nc's
        make(tmp_path / "d.nc.node-a.0123456789abcdef.part", ancient),
    ]
    assert reap_stale_temporaries(tmp_path / "c.nc") == []
    assert reap_stale_temporaries(tmp_path / "c.nc", hidden=True) == []
    assert all(p.exists() for p in others)


def test_a_temporary_renamed_while_it_is_reaped_is_no_error(tmp_path, monkeypatch):
    gone = make(tmp_path / "c.nc.node-a.0123456789abcdef.part", REAP_AGE_S + 60)
    real_stat = type(gone).stat

    def renamed_meanwhile(self, *args, **kwargs):
        result = real_stat(self, *args, **kwargs)
        if self.name == gone.name:
            os.unlink(self)  # its writer renamed it, or another reaper removed it
        return result

    monkeypatch.setattr(type(gone), "stat", renamed_meanwhile)
    assert reap_stale_temporaries(tmp_path / "c.nc") == []


@pytest.mark.parametrize("hidden", [False, True])
def test_a_live_writer_in_another_process_keeps_its_temporary(tmp_path, hidden):
    """A real second process writes while this one makes temporaries for the same output."""
    out = tmp_path / "t.csv"
    child = subprocess.Popen(
        [
            sys.executable,
            "-c",
            "import sys, time\n"
            "from selfsense.io.provenance import temporary_path\n"
            f"tmp = temporary_path(sys.argv[1], hidden={hidden})\n"
            "tmp.write_text('a,b\\n1,')\n"
            "print(tmp, flush=True)\n"
            "sys.stdin.readline()\n"
            "tmp.write_text('a,b\\n1,2\\n')\n"
            "tmp.replace(sys.argv[1])\n",
            str(out),
        ],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
    )
    theirs = child.stdout.readline().strip()
    for _ in range(3):
        write_table(pd.DataFrame({"a": [1], "b": [3]}), out)
    child.communicate("go\n", timeout=60)
    assert child.returncode == 0
    assert out.read_text() == "a,b\n1,2\n" and not os.path.exists(theirs)
