#!/usr/bin/env bash
# Stop the one-node cluster started by ci/slurm/install_slurm.sh: slurmd, slurmctld, then munged.
# Each daemon is stopped by the pid in its own pid file; nothing else is touched. Safe to run twice.
set -uo pipefail

log() { printf '[stop_slurm] %s\n' "$*" >&2; }

stop_pid() {  # stop the daemon whose pid file is $2 (name $1), waiting up to 10 s
    local name=$1 pidfile=$2 pid
    [ -s "$pidfile" ] || return 0
    pid=$(cat "$pidfile")
    if kill -0 "$pid" 2>/dev/null; then
        log "stopping $name (pid $pid)"
        kill "$pid"
        for _ in $(seq 100); do kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
        kill -0 "$pid" 2>/dev/null && { log "$name did not stop; sending SIGKILL"; kill -9 "$pid"; }
    fi
    rm -f "$pidfile"
}

# Jobs still queued or running would be left to a daemon that is going away; cancel them first.
if command -v scancel >/dev/null && scontrol ping >/dev/null 2>&1; then
    scancel --user="$(id -un)" >/dev/null 2>&1 || true
fi
stop_pid slurmd /run/slurmd.pid
stop_pid slurmctld /run/slurmctld.pid
stop_pid munged /run/munge/munged.pid
