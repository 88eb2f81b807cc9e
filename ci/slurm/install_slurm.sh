#!/usr/bin/env bash
# Install Debian's SLURM (slurm-wlm) and munge, and start a one-node cluster on this machine:
# munged, slurmctld and slurmd for `hostname -s`, no accounting database (slurmdbd).
#
# Meant for CI and for trying the slurm profile on a workstation; needs root (apt-get, /etc/slurm, daemons).
# Idempotent: packages already installed are not reinstalled, and running daemons are restarted on the new config.
# Stop everything again with ci/slurm/stop_slurm.sh.
#
# Choices that matter in a container (no systemd, no cgroup v2 delegation):
#   ProctrackType=proctrack/linuxproc, TaskPlugin=task/none, JobAcctGatherType=jobacct_gather/none:
#     no cgroup plugin is loaded, so slurmd starts without a cgroup hierarchy of its own.
#   AccountingStorageType=accounting_storage/none: there is no slurmdbd. `sacct` still exists but knows nothing, so the
#     Snakemake plugin must poll with squeue (`slurm-status-command: squeue`) ...
#   MinJobAge=$MIN_JOB_AGE (default 3600 s): ... and squeue only reports a finished job while slurmctld still
#     remembers it, i.e. for MinJobAge seconds. The plugin falls back to sacct (and hangs) if MinJobAge < 3x its
#     first status-check delay.
#   SlurmUser=root: spool and state directories need no extra ownership handling.
#   SelectType=select/cons_tres with CR_Core_Memory: several jobs share the node by cores and memory, like on a cluster.
set -euo pipefail

MIN_JOB_AGE=${MIN_JOB_AGE:-3600}
CONF_DIR=/etc/slurm
CONF=$CONF_DIR/slurm.conf
STATE_DIR=/var/spool/slurmctld
SPOOL_DIR=/var/spool/slurmd
LOG_DIR=/var/log/slurm
MARKER="# written by spherejam ci/slurm/install_slurm.sh"

log() { printf '[install_slurm] %s\n' "$*" >&2; }

if [ "$(id -u)" -ne 0 ]; then
    log "must run as root (apt-get, /etc/slurm, daemons); try: sudo $0"
    exit 2
fi

# --- packages --------------------------------------------------------------------------------------------------
if ! command -v slurmctld >/dev/null || ! command -v slurmd >/dev/null || ! command -v munged >/dev/null \
        || ! command -v sbatch >/dev/null; then
    log "installing slurm-wlm and munge from Debian"
    export DEBIAN_FRONTEND=noninteractive
    apt-get update -qq
    apt-get install -y -qq --no-install-recommends slurm-wlm munge >/dev/null
fi
log "$(slurmctld -V)"

# --- munge -----------------------------------------------------------------------------------------------------
if [ ! -s /etc/munge/munge.key ]; then
    log "creating /etc/munge/munge.key"
    mkdir -p /etc/munge
    if command -v mungekey >/dev/null; then mungekey --create --force; else
        dd if=/dev/urandom of=/etc/munge/munge.key bs=1 count=1024 status=none; fi
fi
mkdir -p /run/munge /var/log/munge /var/lib/munge
chown munge:munge /etc/munge /etc/munge/munge.key /run/munge /var/log/munge /var/lib/munge
chmod 0700 /etc/munge /var/log/munge
chmod 0400 /etc/munge/munge.key
chmod 0755 /run/munge
if ! munge -n 2>/dev/null | unmunge >/dev/null 2>&1; then
    log "starting munged"
    runuser -u munge -- /usr/sbin/munged
    for _ in $(seq 50); do munge -n 2>/dev/null | unmunge >/dev/null 2>&1 && break; sleep 0.1; done
fi
munge -n | unmunge >/dev/null || { log "munge does not work"; exit 1; }

# --- slurm.conf ------------------------------------------------------------------------------------------------
HOST=$(hostname -s)
# slurmd -C prints this node's real hardware line (CPUs, sockets, cores, RealMemory); a RealMemory larger than the
# real one would put the node into DRAIN, so take it from there and keep 5 % (at least 256 MB) for the daemons.
HW=$(slurmd -C | head -n 1)
CPUS=$(sed -n 's/.*CPUs=\([0-9]*\).*/\1/p' <<<"$HW")
REALMEM=$(sed -n 's/.*RealMemory=\([0-9]*\).*/\1/p' <<<"$HW")
RESERVE=$(( REALMEM / 20 > 256 ? REALMEM / 20 : 256 ))
MEM=$(( REALMEM - RESERVE ))
if [ -e "$CONF" ] && ! grep -qF "$MARKER" "$CONF"; then
    log "$CONF exists and was not written by this script; refusing to overwrite it (move it away first)"
    exit 2
fi
mkdir -p "$CONF_DIR" "$STATE_DIR" "$SPOOL_DIR" "$LOG_DIR"
cat >"$CONF" <<CONF
$MARKER
# One-node test cluster on $HOST; see the comments at the top of that script.
ClusterName=spherejam-ci
SlurmctldHost=$HOST
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CryptoType=crypto/munge
MpiDefault=none
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_Core_Memory
ReturnToService=2
MinJobAge=$MIN_JOB_AGE
KillWait=10
SlurmctldPort=6817
SlurmdPort=6818
StateSaveLocation=$STATE_DIR
SlurmdSpoolDir=$SPOOL_DIR
SlurmctldPidFile=/run/slurmctld.pid
SlurmdPidFile=/run/slurmd.pid
SlurmctldLogFile=$LOG_DIR/slurmctld.log
SlurmdLogFile=$LOG_DIR/slurmd.log
SlurmctldDebug=info
SlurmdDebug=info
NodeName=$HOST CPUs=$CPUS RealMemory=$MEM State=UNKNOWN
PartitionName=debug Nodes=$HOST Default=YES MaxTime=INFINITE State=UP
CONF
log "wrote $CONF: node $HOST, CPUs=$CPUS, RealMemory=$MEM MB, MinJobAge=$MIN_JOB_AGE s"

# --- daemons ---------------------------------------------------------------------------------------------------
stop_pid() {  # stop the daemon whose pid file is $1, if it runs
    local pidfile=$1 pid
    [ -s "$pidfile" ] || return 0
    pid=$(cat "$pidfile")
    if kill -0 "$pid" 2>/dev/null; then
        kill "$pid"
        for _ in $(seq 100); do kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
    fi
    rm -f "$pidfile"
}
stop_pid /run/slurmd.pid
stop_pid /run/slurmctld.pid
log "starting slurmctld and slurmd"
/usr/sbin/slurmctld -i   # -i: ignore state left by an earlier run of this script
for _ in $(seq 100); do scontrol ping >/dev/null 2>&1 && break; sleep 0.2; done
/usr/sbin/slurmd
deadline=$(( SECONDS + 60 ))
state=""
while (( SECONDS < deadline )); do
    state=$(sinfo -h -n "$HOST" -o '%t' 2>/dev/null | head -n 1)
    case "$state" in
        idle|mix|alloc) break ;;
        drain*|down*|inval*) scontrol update nodename="$HOST" state=resume >/dev/null 2>&1 || true ;;
    esac
    sleep 0.5
done
if [[ "$state" != idle && "$state" != mix && "$state" != alloc ]]; then
    log "node $HOST did not become idle (state '$state'); last log lines:"
    tail -n 20 "$LOG_DIR/slurmctld.log" "$LOG_DIR/slurmd.log" >&2 || true
    exit 1
fi
log "cluster up:"
sinfo >&2
