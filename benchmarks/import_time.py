"""How light `import spherejam` is (Snakemake imports it for every DAG it builds; issue 48).

Prints the CPU time (user + sys) of ``python -c "import spherejam"`` minus that of ``python -c pass``, the median of
interleaved runs, for this tree and optionally for another source tree given as the baseline (``--baseline SRC``, e.g.
an older commit's ``src`` from ``git archive``), with their ratio; and the heavy modules the import pulls in (none
expected: the engines, numpy and numba load on first use). CPU time rather than wall time: on a shared machine the
wall time of a 25 ms import varies by a factor 2 between runs.

    python benchmarks/import_time.py [--runs 40] [--baseline /tmp/before/src]
"""

import argparse
import os
import resource
import statistics
import subprocess
import sys
from pathlib import Path

HEAVY = ("numpy", "numba", "scipy", "xarray", "pandas", "h5py", "matplotlib", "highspy", "snakemake", "yaml")


def cpu_seconds(code: str, src: str) -> float:
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    subprocess.run([sys.executable, "-c", code], env=dict(os.environ, PYTHONPATH=src), check=True)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=40)
    parser.add_argument("--baseline", help="another source tree (its src folder) to compare with")
    args = parser.parse_args()
    trees = {"this tree": str(Path(__file__).resolve().parents[1] / "src")}
    if args.baseline:
        trees["baseline"] = args.baseline
    times = {name: [] for name in trees}
    for _ in range(args.runs):
        for name, src in trees.items():
            times[name].append(cpu_seconds("import spherejam", src) - cpu_seconds("pass", src))
    for name, src in trees.items():
        loaded = subprocess.run([sys.executable, "-c", "import sys, spherejam; print(' '.join(m for m in "
                                 f"{HEAVY!r} if m in sys.modules))"], env=dict(os.environ, PYTHONPATH=src),
                                capture_output=True, text=True, check=True).stdout.split()
        print(f"{name}: import spherejam {1e3 * statistics.median(times[name]):.1f} ms CPU (median of {args.runs}); "
              f"heavy modules loaded: {', '.join(loaded) or 'none'}")
    if args.baseline:
        ratio = statistics.median(times["this tree"]) / statistics.median(times["baseline"])
        print(f"this tree / baseline = {ratio:.2f}")


if __name__ == "__main__":
    main()
