#!/usr/bin/env bash
# A single-node SLURM cluster on this machine, from the distribution's packages, to try
# profiles/slurm without a real cluster and for tests/workflow/test_slurm.py.
#
#   scripts/slurm_local.sh [start]   install munge/slurmctld/slurmd (apt) if missing, write the
#                                    config, start the daemons on loopback, wait until the node
#                                    is idle
#   scripts/slurm_local.sh stop      stop the daemons this script started, withdraw the config
#   scripts/slurm_local.sh status    print `sinfo` (exit 1 if the controller does not answer)
#
# Idempotent: `start` on a running cluster only checks it is up. Needs root and apt-get (Debian,
# Ubuntu). Anything that cannot be done ends the script with one line on stderr, exit status 1.
#
# The config is $SLURM_LOCAL_DIR/slurm.conf, linked from /etc/slurm/slurm.conf only while the
# cluster runs: SLURM commands find it there without SLURM_CONF (which the plugin's job step
# strips before its inner `srun`). `stop` removes the link because with a config in place and no
# controller answering every SLURM command waits ≈ 10 s, and so does every `snakemake` start
# once the SLURM plugin is installed (it asks `scontrol show config` to word its --help). If the
# daemons died without `stop` (a reboot, a killed session), `stop` or `start` tidies up.
#
# The cluster: node `localhost` with this machine's CPUs and memory (as `slurmd -C` reads them),
# one partition `main` (the name profiles/slurm asks for), no accounting database (so job states
# come from `squeue`; finished jobs stay visible there for MinJobAge = 300 s), and process tracking
# without cgroups, which containers and small VMs often do not delegate. Daemons run as root and
# keep their config, state, logs and pid files in $SLURM_LOCAL_DIR (default /var/tmp/selfsense-slurm).
set -euo pipefail

STATE=${SLURM_LOCAL_DIR:-/var/tmp/selfsense-slurm}
CONF=$STATE/slurm.conf
LINK=/etc/slurm/slurm.conf
# this script's own SLURM commands use the config whether or not the link is there
export SLURM_CONF=$CONF
PACKAGES=(munge slurmctld slurmd slurm-client)
PARTITION=main
POLICY=/usr/sbin/policy-rc.d

die() {
    echo "slurm_local.sh: $*" >&2
    exit 1
}

alive() { # pid file -> true if that process runs
    [[ -s $1 ]] && kill -0 "$(cat "$1")" 2>/dev/null
}

need_root() {
    [[ $(id -u) == 0 ]] || die "must run as root (installs packages, starts daemons)"
}

install_packages() {
    local cmd missing=0
    for cmd in munged mungekey slurmctld slurmd sinfo sbatch squeue scontrol srun; do
        command -v "$cmd" >/dev/null || missing=1
    done
    ((missing)) || return 0
    command -v apt-get >/dev/null || die "no apt-get here: install ${PACKAGES[*]} by hand"
    # The packages would start their daemons on install, before there is a config; Debian's
    # policy-rc.d hook (exit 101: "do not start") prevents that. Container images often have one.
    if [[ ! -e $POLICY ]]; then
        printf '#!/bin/sh\nexit 101\n' >"$POLICY" && chmod +x "$POLICY"
        trap 'rm -f "$POLICY"' EXIT
    fi
    # another apt-get (the report's browser test installing Chromium beside this one) holds
    # dpkg's lock for a while: wait for it instead of failing
    local wait=(-o DPkg::Lock::Timeout=900)
    { apt-get "${wait[@]}" update -q && DEBIAN_FRONTEND=noninteractive apt-get "${wait[@]}" install \
        -y -q --no-install-recommends "${PACKAGES[@]}"; } >"$STATE/apt.log" 2>&1 ||
        die "apt-get install ${PACKAGES[*]} failed (log: $STATE/apt.log)"
}

ours() { # true if the default config place is our link
    [[ -L $LINK && $(readlink "$LINK") == "$CONF" ]]
}

write_config() {
    if [[ -e $LINK || -L $LINK ]] && ! ours; then
        die "$LINK exists and is not this script's: a cluster is configured here already (sinfo)"
    fi
    # the node's CPUs, topology and memory exactly as slurmd measures them: a node configured
    # with more than it has is drained at registration
    local hw
    hw=$(slurmd -C | head -1 | tr ' ' '\n' | grep -E '^(CPUs|Boards|SocketsPerBoard|CoresPerSocket|ThreadsPerCore|RealMemory)=' | tr '\n' ' ') \
        || die "slurmd -C could not read this machine's CPUs and memory"
    mkdir -p "$STATE/state" "$STATE/spool"
    cat >"$CONF.new" <<EOF
ClusterName=selfsense
SlurmctldHost=localhost
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
StateSaveLocation=$STATE/state
SlurmdSpoolDir=$STATE/spool
SlurmctldPidFile=$STATE/slurmctld.pid
SlurmdPidFile=$STATE/slurmd.pid
SlurmctldLogFile=$STATE/slurmctld.log
SlurmdLogFile=$STATE/slurmd.log
# no cgroups: plain /proc process tracking, no task containment
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
MpiDefault=none
MailProg=/bin/true
# cores and memory are both consumable, so jobs asking --mem share the node as they fit
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_Core_Memory
# a node that was down (e.g. after a restart) returns when its slurmd registers
ReturnToService=2
MinJobAge=300
NodeName=localhost NodeAddr=127.0.0.1 $hw State=UNKNOWN
PartitionName=$PARTITION Nodes=localhost Default=YES MaxTime=INFINITE State=UP
EOF
    if ! cmp -s "$CONF.new" "$CONF"; then
        mv "$CONF.new" "$CONF"
        # running daemons read the new config (e.g. after a memory change) without a restart
        if alive "$STATE/slurmctld.pid"; then scontrol reconfigure >/dev/null || die "scontrol reconfigure failed"; fi
    else
        rm "$CONF.new"
    fi
}

start_munge() {
    if munge -n </dev/null 2>/dev/null | unmunge >/dev/null 2>&1; then
        return 0 # a munged answers already (ours or the system's)
    fi
    if [[ ! -s /etc/munge/munge.key ]]; then
        mungekey --create --keyfile=/etc/munge/munge.key >>"$STATE/munged.log" 2>&1 || die "could not create /etc/munge/munge.key"
    fi
    chown munge:munge /etc/munge/munge.key && chmod 600 /etc/munge/munge.key
    mkdir -p /run/munge "$STATE/munge" && chown munge:munge /run/munge "$STATE/munge"
    # munged refuses to run as root
    runuser -u munge -- munged --pid-file="$STATE/munge/munged.pid" >>"$STATE/munged.log" 2>&1 \
        || die "munged did not start (log: $STATE/munged.log)"
    munge -n </dev/null | unmunge >/dev/null 2>&1 || die "munged runs but does not answer (log: $STATE/munged.log)"
}

start_daemon() { # name, pid file, command...
    local name=$1 pid=$2
    shift 2
    alive "$pid" && return 0
    "$@" >>"$STATE/$name.start.log" 2>&1 || die "$name did not start (logs: $STATE/$name.log, $STATE/$name.start.log)"
}

wait_idle() {
    local state=""
    for _ in $(seq 60); do
        state=$(sinfo -h -N -n localhost -o %t 2>/dev/null || true)
        case $state in
            idle | mix | alloc) return 0 ;;
            down* | drain* | drng*) scontrol update NodeName=localhost State=RESUME >/dev/null 2>&1 || true ;;
        esac
        alive "$STATE/slurmctld.pid" || die "slurmctld exited (log: $STATE/slurmctld.log)"
        alive "$STATE/slurmd.pid" || die "slurmd exited (log: $STATE/slurmd.log)"
        sleep 1
    done
    die "node localhost is '${state:-not listed}' after 60 s, not idle (logs: $STATE/slurmctld.log, $STATE/slurmd.log)"
}

start() {
    need_root
    mkdir -p "$STATE"
    install_packages
    write_config
    start_munge
    start_daemon slurmctld "$STATE/slurmctld.pid" slurmctld
    start_daemon slurmd "$STATE/slurmd.pid" slurmd -N localhost
    wait_idle
    mkdir -p "$(dirname "$LINK")" && ln -sfn "$CONF" "$LINK"
    echo "slurm_local.sh: node localhost idle in partition $PARTITION (config $CONF, linked from $LINK)"
}

stop_pid() { # pid file: TERM, then wait up to 20 s for the process to go
    local pid
    alive "$1" || return 0
    pid=$(cat "$1")
    kill "$pid"
    for _ in $(seq 20); do
        kill -0 "$pid" 2>/dev/null || return 0
        sleep 1
    done
    die "process $pid ($1) did not stop"
}

stop() {
    need_root
    stop_pid "$STATE/slurmd.pid"
    stop_pid "$STATE/slurmctld.pid"
    stop_pid "$STATE/munge/munged.pid"
    if ours; then rm "$LINK"; fi
    echo "slurm_local.sh: stopped"
}

case ${1:-start} in
    start) start ;;
    stop) stop ;;
    status) # the pid file first: sinfo would wait for a controller that is not there
        alive "$STATE/slurmctld.pid" || die "not running (scripts/slurm_local.sh start)"
        sinfo ;;
    *) die "usage: scripts/slurm_local.sh [start|stop|status]" ;;
esac
