#!/usr/bin/env bash
# A private one-node Slurm cluster for tests (Debian 12's slurm-wlm 22.05 and munge), run as
# root and kept entirely inside one folder: its own munge key and socket, its own slurm.conf
# (on ports of its own), spool, state, pid and log files. Nothing is written to /etc, /run or
# /var, so it neither needs nor leaves configuration behind, and it does not disturb a Slurm
# already running on the machine.
#
#   tests/slurm/cluster.sh install         # apt-get install -y slurm-wlm munge (after apt-get update)
#   tests/slurm/cluster.sh start DIR       # writes DIR/slurm.conf, starts munged, slurmctld, slurmd
#   tests/slurm/cluster.sh stop DIR        # cancels its jobs, stops the three daemons it started
#
# Clients (sbatch, squeue, scontrol) talk to it with SLURM_CONF=DIR/slurm.conf. `start` exits
# 3, with the reason on standard error, when Slurm cannot be started here (not installed, not
# root, a daemon that does not start or a node that does not come up, with its log's last
# lines): the caller decides whether that skips or fails a test. Run `stop` after a failed
# `start` too: it stops whatever did start.
set -euo pipefail
# The daemons live in /usr/sbin, which a user's PATH may lack.
PATH="$PATH:/usr/sbin:/sbin"

cmd=${1:?usage: cluster.sh install | start DIR | stop DIR}

cannot() {
    echo "cluster.sh: Slurm cannot be started here: $*" >&2
    exit 3
}

pid_of() { # the pid in a pid file, if that process is alive
    local f=$1 p
    [ -f "$f" ] || return 1
    p=$(cat "$f" 2>/dev/null) || return 1
    [ -n "$p" ] && kill -0 "$p" 2>/dev/null && echo "$p"
}

stop_pid_file() { # TERM the daemon of a pid file, then KILL it after 10 s
    local f=$1 p i
    p=$(pid_of "$f") || return 0
    kill "$p" 2>/dev/null || true
    for i in $(seq 100); do
        kill -0 "$p" 2>/dev/null || return 0
        sleep 0.1
    done
    kill -9 "$p" 2>/dev/null || true
}

case "$cmd" in
    install)
        export DEBIAN_FRONTEND=noninteractive
        apt-get install -y slurm-wlm munge
        ;;
    start)
        dir=${2:?cluster folder}
        for tool in munged mungekey slurmctld slurmd sbatch scontrol squeue; do
            command -v "$tool" >/dev/null || cannot "$tool is not installed (apt-get install -y slurm-wlm munge)"
        done
        [ "$(id -u)" -eq 0 ] || cannot "the daemons are started as root, and this is user $(id -un)"
        mkdir -p "$dir"
        dir=$(cd "$dir" && pwd)
        # munge checks that no one else can write where its socket and key are.
        chmod 700 "$dir"
        mkdir -p "$dir/munge" "$dir/ctld" "$dir/spool"
        chmod 700 "$dir/munge"
        [ -f "$dir/munge/munge.key" ] || mungekey --create --keyfile="$dir/munge/munge.key" 2>/dev/null \
            || dd if=/dev/urandom of="$dir/munge/munge.key" bs=1024 count=1 status=none
        chmod 400 "$dir/munge/munge.key"
        munged --force --socket="$dir/munge/socket" --key-file="$dir/munge/munge.key" \
            --pid-file="$dir/munge/munged.pid" --log-file="$dir/munge/munged.log" \
            --seed-file="$dir/munge/munged.seed" \
            || cannot "munged did not start: $(tail -n 5 "$dir/munge/munged.log" 2>/dev/null)"

        host=$(hostname -s)
        cpus=$(nproc)
        cat >"$dir/slurm.conf" <<EOF
# Written by tests/slurm/cluster.sh: a one-node cluster private to $dir.
ClusterName=pirtest
SlurmctldHost=$host(127.0.0.1)
SlurmctldPort=${SLURMCTLD_PORT:-16817}
SlurmdPort=${SLURMD_PORT:-16818}
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$dir/munge/socket
StateSaveLocation=$dir/ctld
SlurmdSpoolDir=$dir/spool
SlurmctldPidFile=$dir/slurmctld.pid
SlurmdPidFile=$dir/slurmd.pid
SlurmctldLogFile=$dir/slurmctld.log
SlurmdLogFile=$dir/slurmd.log
PlugStackConfig=$dir/plugstack.conf
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
SchedulerType=sched/backfill
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
MpiDefault=none
ReturnToService=2
JobRequeue=1
MinJobAge=600
NodeName=$host NodeAddr=127.0.0.1 CPUs=$cpus State=UNKNOWN
PartitionName=test Nodes=$host Default=YES MaxTime=INFINITE State=UP
EOF
        : >"$dir/plugstack.conf"
        export SLURM_CONF="$dir/slurm.conf"
        slurmctld || cannot "slurmctld did not start: $(tail -n 5 "$dir/slurmctld.log" 2>/dev/null)"
        slurmd || cannot "slurmd did not start: $(tail -n 5 "$dir/slurmd.log" 2>/dev/null)"
        # Wait for the node to be idle (at most 60 s).
        for i in $(seq 120); do
            if [ "$i" -gt 4 ]; then
                for daemon in slurmctld slurmd; do
                    pid_of "$dir/$daemon.pid" >/dev/null || cannot "$daemon exited; its log ends with:
$(tail -n 5 "$dir/$daemon.log" 2>&1)"
                done
            fi
            state=$(sinfo -h -n "$host" -o %t 2>/dev/null || true)
            if [ "$state" = idle ]; then
                echo "cluster.sh: Slurm is up in $dir (node $host, $cpus CPUs)"
                exit 0
            fi
            sleep 0.5
        done
        cannot "the node did not become idle in 60 s (state '${state:-?}'); the logs end with:
$(tail -n 10 "$dir/slurmctld.log" "$dir/slurmd.log" "$dir/munge/munged.log" 2>&1)"
        ;;
    stop)
        dir=${2:?cluster folder}
        export SLURM_CONF="$dir/slurm.conf"
        if pid_of "$dir/slurmctld.pid" >/dev/null; then
            # Every job of this private cluster is the caller's.
            jobs=$(squeue -h -o %A 2>/dev/null || true)
            if [ -n "$jobs" ]; then
                # shellcheck disable=SC2086
                scancel $jobs 2>/dev/null || true
                sleep 1
            fi
        fi
        stop_pid_file "$dir/slurmd.pid"
        stop_pid_file "$dir/slurmctld.pid"
        stop_pid_file "$dir/munge/munged.pid"
        echo "cluster.sh: stopped the Slurm of $dir"
        ;;
    *)
        echo "usage: cluster.sh install | start DIR | stop DIR" >&2
        exit 2
        ;;
esac
