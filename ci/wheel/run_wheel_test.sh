#!/usr/bin/env bash
# Issue 48: spherejam as a user gets it. Build the sdist and the wheel (python -m build, the wheel from the sdist),
# check that the wheel's workflow files are the repository's, install the wheel alone into a clean venv, and from an
# empty folder run what a new user would: `spherejam rcp SPEC --dry-run`, `spherejam init` + `spherejam run` on the
# tiny config to completion, `spherejam browse` on its dataset, spherejam.jam() from Python and `spherejam view`.
# The venv gets its dependencies from the package registry and numba compiles afresh (its own cache).
#
# Usage: ci/wheel/run_wheel_test.sh [--work DIR] [--keep]
#   --work DIR  where the build, the venvs and the empty folder go (default: a new folder under /tmp)
#   --keep      leave the work folder (it is removed after a successful run otherwise)
set -euo pipefail

REPO=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
WORK=""
KEEP=0
while [ $# -gt 0 ]; do
    case "$1" in
        --work) WORK=$2; shift 2 ;;
        --keep) KEEP=1; shift ;;
        -h|--help) sed -n '2,10p' "$0"; exit 0 ;;
        *) echo "run_wheel_test.sh: unknown argument $1" >&2; exit 2 ;;
    esac
done
WORK=${WORK:-$(mktemp -d /tmp/spherejam-wheel.XXXXXX)}
mkdir -p "$WORK"
START=$SECONDS
step() { echo "== wheel test, $((SECONDS - START)) s: $*"; }

step "build the sdist and the wheel"
python -m venv "$WORK/build-env"
"$WORK/build-env/bin/python" -m pip install --quiet --disable-pip-version-check build
"$WORK/build-env/bin/python" -m build --outdir "$WORK/dist" "$REPO" > "$WORK/build.log" 2>&1 \
    || { tail -30 "$WORK/build.log"; exit 1; }
WHEEL=$(ls "$WORK"/dist/spherejam-*.whl)
echo "wheel: $(basename "$WHEEL"), $(stat -c %s "$WHEEL") bytes; sdist: $(stat -c %s "$WORK"/dist/spherejam-*.tar.gz) bytes"

step "the wheel's workflow files are the repository's"
(cd "$REPO" && SPHEREJAM_WHEEL="$WHEEL" python -m pytest -q -p no:cacheprovider \
    tests/workflow/test_packaged.py -k test_wheel_carries_the_repository_files)

step "install the wheel alone into a clean venv"
python -m venv "$WORK/venv"
"$WORK/venv/bin/python" -m pip install --quiet --disable-pip-version-check "$WHEEL"

# From here on nothing of the repository: an empty folder, the venv's own spherejam, a fresh numba cache.
mkdir -p "$WORK/empty"
cd "$WORK/empty"
unset PYTHONPATH
export NUMBA_CACHE_DIR="$WORK/numba-cache" MPLBACKEND=Agg
SJ="$WORK/venv/bin/spherejam"
PY="$WORK/venv/bin/python"
"$PY" -c "import spherejam, sys; assert spherejam.__file__.startswith('$WORK/venv'), spherejam.__file__"

step "spherejam rcp --dry-run"
"$SJ" rcp "bidisperse:ratio=1.4,small=0.5,by=number" --dry-run > rcp.log
grep -q "cost estimate" rcp.log

step "spherejam init + spherejam run on the tiny config"
"$SJ" init exp --from tiny
"$SJ" run --configfile exp/config.yaml -o out --cores 2 > run.log 2>&1 || { tail -40 run.log; exit 1; }
for f in out/dataset.nc out/tables/table4.csv out/figures/fig5.png; do
    [ -s "$f" ] || { echo "spherejam run: $f missing" >&2; exit 1; }
done
"$SJ" browse out/dataset.nc > browse.log
grep -q "packings" browse.log

step "spherejam.jam() from Python, then spherejam view"
"$PY" - <<'EOF'
import spherejam

r = spherejam.jam(n=64, psd="lognormal:sigma=0.2", closest={"final_rate": 1e-1}, certify=True, seed=3)
print(r)
assert r.phi < r.phi_J < 0.7 and r.certificate.isostatic, r
spherejam.write_packing("jam.h5", r.packing)
EOF
"$SJ" view jam.h5 -o jam.html
JAMMED=$(find out/packings -name jammed.h5 | head -1)
"$SJ" view "$JAMMED" -o workflow.html
grep -q 'id="packing"' workflow.html

step "done"
cd /
[ "$KEEP" -eq 1 ] || rm -rf "$WORK"
