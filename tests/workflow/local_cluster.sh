#!/usr/bin/env bash
# A throw-away single-node SLURM cluster on this machine, for tests and benchmarks.
#
#   eval "$(tests/workflow/local_cluster.sh start [DIR])"   start munged, slurmctld and slurmd, and
#                                                           point this shell's clients at them
#   tests/workflow/local_cluster.sh stop DIR                cancel its jobs and stop its daemons
#
# Everything lives in DIR (default: a new /tmp/ldpipe-slurm.XXXXXX): its own munge key and socket,
# slurm.conf on two free TCP ports, state, spool, pid and log files. Nothing under /etc is read or
# written and nothing listens beyond 127.0.0.1, so it can run beside a real installation.
# Clients (sbatch, squeue, Snakemake's slurm executor) find it through SLURM_CONF, which `start`
# prints as shell to evaluate, with DIR/bin put first on PATH: the srun there sets SLURM_CONF
# again, because Snakemake's job-step executor strips SLURM_* variables from the srun it starts
# inside each job (a real cluster keeps its configuration where srun looks by default).
# Needs root (SlurmUser=root; munged runs as the munge user) and Debian's slurm-wlm and munge.
# Accounting is off, so submissions need no account and squeue is the status command.
set -euo pipefail

die() { echo "local_cluster: $*" >&2; exit 1; }

PATH=$PATH:/usr/sbin:/sbin  # the daemons live there, and a non-login root shell may lack it

free_port() {
    python3 -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])'
}

stop_pid_file() {  # stop the daemon whose pid file is $1, if it is still running; SIGKILL after 10 s
    local pid_file=$1 pid
    [[ -s $pid_file ]] || return 0
    pid=$(<"$pid_file")
    kill -0 "$pid" 2>/dev/null || return 0
    kill -TERM "$pid" 2>/dev/null || true
    for _ in $(seq 100); do kill -0 "$pid" 2>/dev/null || return 0; sleep 0.1; done
    kill -KILL "$pid" 2>/dev/null || true
}

stop() {
    local dir=$1
    [[ -d $dir/munge ]] || die "$dir holds no cluster started by this script"
    export SLURM_CONF=$dir/slurm.conf
    if [[ -s $dir/slurmctld.pid ]] && kill -0 "$(<"$dir/slurmctld.pid")" 2>/dev/null; then
        # Jobs of this private cluster only: SLURM_CONF names it.
        timeout 10 scancel --quiet --full --user=root 2>/dev/null || true
        timeout 10 scontrol shutdown 2>/dev/null || true
    fi
    stop_pid_file "$dir/slurmd.pid"
    stop_pid_file "$dir/slurmctld.pid"
    stop_pid_file "$dir/munge/munged.pid"
}

start() {
    local dir=${1:-}
    [[ $EUID -eq 0 ]] || die "must run as root (SlurmUser=root, munged as the munge user)"
    local tool
    for tool in munged slurmctld slurmd sinfo scontrol srun runuser python3; do
        command -v "$tool" >/dev/null || die "'$tool' not found (apt-get install slurm-wlm munge)"
    done
    id munge >/dev/null 2>&1 || die "no 'munge' user (apt-get install munge)"
    if [[ -z $dir ]]; then dir=$(mktemp -d /tmp/ldpipe-slurm.XXXXXX); else mkdir -p "$dir"; fi
    dir=$(cd "$dir" && pwd)
    chmod 755 "$dir"  # munged (as munge) and slurmstepd must reach the socket and spool

    # munge: a private key and socket, owned by the munge user as munged insists.
    mkdir -p "$dir/munge"
    dd if=/dev/urandom of="$dir/munge/munge.key" bs=1024 count=1 status=none
    chown -R munge:munge "$dir/munge"
    chmod 755 "$dir/munge"  # clients (root) and slurmstepd reach the socket through it
    chmod 400 "$dir/munge/munge.key"
    runuser -u munge -- munged --socket="$dir/munge/munge.socket" --key-file="$dir/munge/munge.key" \
        --pid-file="$dir/munge/munged.pid" --log-file="$dir/munge/munged.log" \
        --seed-file="$dir/munge/munged.seed" || die "munged did not start (see $dir/munge/munged.log)"

    # The node as slurmd sees it, with 5% of the memory held back so the node is never drained
    # for reporting less memory than configured.
    local host node memory
    host=$(hostname)
    node=$(slurmd -C | head -1)
    memory=$(sed -n 's/.*RealMemory=\([0-9]*\).*/\1/p' <<<"$node")
    node=$(sed -e "s/^NodeName=[^ ]*//" -e "s/RealMemory=[0-9]*/RealMemory=$((memory * 95 / 100))/" <<<"$node")
    mkdir -p "$dir/state" "$dir/spool" "$dir/bin"
    printf '#!/bin/sh\nexport SLURM_CONF=%s\nexec %s "$@"\n' "$dir/slurm.conf" "$(command -v srun)" >"$dir/bin/srun"
    chmod 755 "$dir/bin/srun"
    cat >"$dir/slurm.conf" <<CONF
# Written by tests/workflow/local_cluster.sh: a single-node test cluster, accounting off.
ClusterName=ldpipe-local
SlurmctldHost=$host(127.0.0.1)
SlurmctldPort=$(free_port)
SlurmdPort=$(free_port)
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
AuthInfo=socket=$dir/munge/munge.socket
CredType=cred/munge
StateSaveLocation=$dir/state
SlurmdSpoolDir=$dir/spool
SlurmctldPidFile=$dir/slurmctld.pid
SlurmdPidFile=$dir/slurmd.pid
SlurmctldLogFile=$dir/slurmctld.log
SlurmdLogFile=$dir/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core_Memory
SchedulerType=sched/backfill
AccountingStorageType=accounting_storage/none
JobAcctGatherType=jobacct_gather/none
JobCompType=jobcomp/none
MpiDefault=none
ReturnToService=2
MinJobAge=300
KillWait=5
InactiveLimit=0
NodeName=$host NodeAddr=127.0.0.1 $node State=UNKNOWN
PartitionName=local Nodes=ALL Default=YES MaxTime=INFINITE State=UP
CONF
    export SLURM_CONF=$dir/slurm.conf
    slurmctld -f "$SLURM_CONF" || { stop "$dir"; die "slurmctld did not start (see $dir/slurmctld.log)"; }
    slurmd -f "$SLURM_CONF" || { stop "$dir"; die "slurmd did not start (see $dir/slurmd.log)"; }

    local state=""
    for _ in $(seq 60); do
        state=$(timeout 5 sinfo --noheader --format=%t 2>/dev/null || true)
        if [[ $state == idle ]]; then
            printf 'export SLURM_CONF=%q\nexport PATH=%q:"$PATH"\n' "$SLURM_CONF" "$dir/bin"
            return 0
        fi
        sleep 0.5
    done
    {
        echo "local_cluster: the node did not become idle within 30 s (state: '${state:-none}')"
        tail -n 5 "$dir/slurmctld.log" "$dir/slurmd.log" "$dir/munge/munged.log" 2>/dev/null || true
    } >&2
    stop "$dir"
    exit 1
}

case ${1:-} in
    start) start "${2:-}" ;;
    stop) [[ -n ${2:-} ]] || die "usage: $0 stop DIR"; stop "$2" ;;
    *) die "usage: $0 start [DIR] | stop DIR" ;;
esac
