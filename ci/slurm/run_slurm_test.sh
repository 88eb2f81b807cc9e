#!/usr/bin/env bash
# End-to-end test of the SLURM profile: run the workflow with a small config once through SLURM (Snakemake's slurm
# executor, profiles/slurm) and once locally (--cores 2), into two results folders, and check that the two
# datasets hold the same numbers (ci/slurm/compare_datasets.py; wall times left out).
#
# Needs root: it installs and starts a one-node SLURM cluster with ci/slurm/install_slurm.sh (Debian's slurm-wlm and
# munge), unless one is already running, and stops the daemons it started when it ends (also on failure).
#
# Usage: ci/slurm/run_slurm_test.sh [--config FILE] [--workflow DIR] [--work DIR] [--keep]
#   --config FILE   workflow config, relative to the workflow folder (default config/tiny.yaml)
#   --workflow DIR  folder with the Snakefile and profiles/ (default: this repository)
#   --work DIR      where the two results folders and logs go (default: a new folder under /tmp)
#   --keep          leave the work folder (it is removed after a successful run otherwise)
# Each Snakemake run is stopped after $SLURM_TEST_TIMEOUT seconds (default 900).
set -euo pipefail

HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
REPO=$(cd "$HERE/../.." && pwd)
WORKFLOW=$REPO
CONFIG=config/tiny.yaml
WORK=""
KEEP=0
LIMIT=${SLURM_TEST_TIMEOUT:-900}
while [ $# -gt 0 ]; do
    case "$1" in
        --config) CONFIG=$2; shift 2 ;;
        --workflow) WORKFLOW=$(cd "$2" && pwd); shift 2 ;;
        --work) WORK=$2; shift 2 ;;
        --keep) KEEP=1; shift ;;
        -h|--help) sed -n '2,15p' "$0"; exit 0 ;;
        *) echo "run_slurm_test: unknown argument $1" >&2; exit 2 ;;
    esac
done
[ -n "$WORK" ] || WORK=$(mktemp -d /tmp/spherejam-slurm-test.XXXXXX)
mkdir -p "$WORK"
WORK=$(cd "$WORK" && pwd)

log() { printf '[slurm-test] %s\n' "$*" >&2; }
T0=$SECONDS

# --- the executor plugin: the `slurm` extra of pyproject.toml ---------------------------------------------------
if ! python -c "import snakemake_executor_plugin_slurm" 2>/dev/null; then
    mapfile -t REQS < <(python - "$REPO/pyproject.toml" <<'EOF'
import sys, tomllib
with open(sys.argv[1], "rb") as f:
    print("\n".join(tomllib.load(f)["project"]["optional-dependencies"]["slurm"]))
EOF
)
    log "installing the slurm extra: ${REQS[*]}"
    python -m pip install -q "${REQS[@]}"
fi

# --- the cluster -------------------------------------------------------------------------------------------------
STARTED_CLUSTER=0
if sinfo -h -o '%t' 2>/dev/null | grep -qE '^(idle|mix|alloc)'; then
    log "using the running SLURM cluster"
else
    bash "$HERE/install_slurm.sh"
    STARTED_CLUSTER=1
fi
cleanup() {
    local rc=$?
    if [ "$STARTED_CLUSTER" = 1 ]; then bash "$HERE/stop_slurm.sh" || true; fi
    if [ "$rc" = 0 ] && [ "$KEEP" = 0 ]; then rm -rf "$WORK"; else log "work folder kept: $WORK"; fi
    exit "$rc"
}
trap cleanup EXIT
T_CLUSTER=$((SECONDS - T0))

cd "$WORKFLOW"
[ -f "$CONFIG" ] || { log "no config $CONFIG in $WORKFLOW"; exit 2; }
COMMON=(--configfile "$CONFIG" --nocolor)

# --- local run (also warms numba's cache for the SLURM jobs) ---------------------------------------------------
log "local run: snakemake --cores 2 --configfile $CONFIG --config results=$WORK/local"
T1=$SECONDS
if ! timeout -s INT -k 60 "$LIMIT" snakemake --workflow-profile "$WORKFLOW/profiles/default" --cores 2 "${COMMON[@]}" \
        --config results="$WORK/local" >"$WORK/local.log" 2>&1; then
    tail -n 40 "$WORK/local.log" >&2
    log "FAILED: local run (log $WORK/local.log)"
    exit 1
fi
T_LOCAL=$((SECONDS - T1))

# --- SLURM run ---------------------------------------------------------------------------------------------------
# Test-only flags: poll every few seconds instead of 40 s, keep the job logs.
log "SLURM run: snakemake --workflow-profile profiles/slurm --configfile $CONFIG --config results=$WORK/slurm"
T2=$SECONDS
FIRST_JOB=$(squeue -h --states=all -o '%i' 2>/dev/null | sort -n | tail -n 1)
if ! timeout -s INT -k 60 "$LIMIT" snakemake --workflow-profile "$WORKFLOW/profiles/slurm" "${COMMON[@]}" --config results="$WORK/slurm" \
        --slurm-init-seconds-before-status-checks 2 --slurm-keep-successful-logs \
        --slurm-logdir "$WORK/slurm-logs" --latency-wait 10 --keep-going \
        >"$WORK/slurm.log" 2>&1; then
    tail -n 60 "$WORK/slurm.log" >&2
    for f in $(ls -t $(find "$WORK/slurm-logs" -name '*.log' 2>/dev/null) 2>/dev/null | head -n 3); do
        log "--- $f"; tail -n 20 "$f" >&2
    done
    log "FAILED: SLURM run (log $WORK/slurm.log)"
    exit 1
fi
T_SLURM=$((SECONDS - T2))

# The jobs must really have gone through SLURM: count the submissions and their final states.
SUBMITTED=$(grep -c "submitted with SLURM jobid" "$WORK/slurm.log" || true)
STATES=$(squeue -h --states=all -o '%i %T' | awk -v first="${FIRST_JOB:-0}" '$1 > first {print $2}' | sort | uniq -c \
    | tr '\n' ' ')
CPUS=$(squeue -h --states=all -o '%i %C' | awk -v first="${FIRST_JOB:-0}" '$1 > first {print $2}' | sort | uniq -c \
    | awk '{printf "%s x %s CPU ", $1, $2}')
log "SLURM jobs submitted: $SUBMITTED; final states: $STATES; requests: $CPUS"
if [ "$SUBMITTED" -lt 1 ]; then
    log "FAILED: no job was submitted to SLURM"
    exit 1
fi

# --- same numbers? -----------------------------------------------------------------------------------------------
if ! python "$HERE/compare_datasets.py" "$WORK/slurm/dataset.nc" "$WORK/local/dataset.nc"; then
    log "FAILED: the SLURM and local datasets differ"
    exit 1
fi
log "OK: SLURM and local datasets agree. Seconds: cluster start $T_CLUSTER, local run $T_LOCAL," \
    "SLURM run $T_SLURM ($SUBMITTED sbatch submissions), total $((SECONDS - T0))"
