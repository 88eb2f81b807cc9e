"""Instructions per compiled function: valgrind's callgrind over one run, with numba's JIT code named
(docs/containers.md §8). Callgrind names code without symbols by its address; the case process, once its run is
over, writes the address of every function of every compiled library it loaded (numba's cached object code), and
this script folds callgrind's self costs onto those names.

    python benchmarks/jit_profile.py periodic OUT [--src TREE/src]   # instructions.py's case: N = 1000, sigma = 0
    python benchmarks/jit_profile.py cylinder OUT                    # containers_spheropack.py's tube, seed 1
    python benchmarks/jit_profile.py table OUT_A OUT_B               # both profiles side by side, largest change first

Each profile counts the whole process (imports, numba's cache, the start and the run). numba is compiled for a
generic CPU (``NUMBA_CPU_NAME=generic``), as in instructions.py, and warmed by one run outside valgrind first.
"""

from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys


def case(kind: str, out: str) -> None:
    import numpy as np
    from numba.core.registry import CPUDispatcher

    from spherejam.core.seeding import poisson_packing
    from spherejam.engines.lubachevsky_stillinger import run_ls

    if kind == "periodic":
        start = run_ls(poisson_packing(1000, 0.0, seed=12345), 1.0, seed=7, target_phi=0.58,
                       progress_interval=1e9).packing
        r = run_ls(start, 1e-2, seed=3, progress_interval=1e9)
    else:
        run_ls(poisson_packing(50, seed=1, container="cylinder:diameter=4"), 1.0, progress_interval=1e9)
        start = poisson_packing(725, seed=1, container="cylinder:diameter=7", phi_nominal=0.54)
        r = run_ls(start, 0.01, seed=1, progress_interval=1e9)
    print(f"phi={r.packing.phi:.15f} collisions={r.stats.collisions}", flush=True)
    np.savez(out + ".npz", x=r.packing.positions, d=r.packing.diameters)
    seen = set()
    with open(out + ".symbols", "w") as f:
        for name, module in list(sys.modules.items()):
            if not name.startswith("spherejam"):
                continue
            for obj in list(vars(module).values()):
                if not isinstance(obj, CPUDispatcher):
                    continue
                for cres in obj.overloads.values():
                    lib = cres.library
                    if id(lib) in seen:
                        continue
                    seen.add(id(lib))
                    llvm_module = getattr(lib, "_shared_module", None) or lib._final_module
                    for fn in llvm_module.functions:
                        if not fn.is_declaration:
                            address = lib.get_pointer_to_function(fn.name)
                            if address:
                                f.write(f"{address:#x} {fn.name}\n")


def _demangle(symbol: str) -> str:
    """``spherejam.engines.kernels.event_driven.run_events`` of numba's ``_ZN...9spherejam7engines...B3v88...``."""
    k = symbol.find("9spherejam")
    if k < 0:
        return symbol[:40]
    parts = []
    while k < len(symbol) and symbol[k].isdigit():
        m = re.match(r"\d+", symbol[k:])
        n = int(m.group(0))
        k += len(m.group(0))
        parts.append(symbol[k:k + n])
        k += n
    return ".".join(parts[1:])


def profile(path: str) -> dict[str, int]:
    """Self instructions per function of a callgrind file, JIT functions by their Python name."""
    names = {}
    for line in open(path + ".symbols"):
        address, symbol = line.split()
        label = _demangle(symbol) + (" (wrapper)" if "cpython" in symbol or "cfunc" in symbol else "")
        names[int(address, 16) & 0xFFFFFFFF] = "jit:" + label  # valgrind maps the JIT pages below 4 GB
    text = subprocess.run(["callgrind_annotate", "--inclusive=no", path], capture_output=True, text=True,
                          check=True).stdout
    out: dict[str, int] = {}
    for line in text.splitlines():
        m = re.match(r"\s*([\d,]+) \(\s*[\d.]+%\)\s+(.*)", line)
        if not m:
            continue
        ir, where = int(m.group(1).replace(",", "")), m.group(2)
        h = re.search(r"\?\?\?:0x([0-9a-f]+)", where)
        key = names.get(int(h.group(1), 16) & 0xFFFFFFFF, where[:60]) if h else re.sub(r"\s*\[.*", "", where)
        key = key if h or "PROGRAM TOTALS" in key else key.split("/")[-1]
        out[key] = out.get(key, 0) + ir
    return out


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("mode", choices=["periodic", "cylinder", "table", "case"])
    ap.add_argument("paths", nargs="+")
    ap.add_argument("--src", help="a tree's src directory (default: this PYTHONPATH)")
    ap.add_argument("--kind", default="periodic")
    args = ap.parse_args()
    if args.mode == "case":
        case(args.kind, args.paths[0])
        return
    if args.mode == "table":
        a, b = profile(args.paths[0]), profile(args.paths[1])
        engine = [sum(v for k, v in p.items() if k.startswith("jit:")) for p in (a, b)]
        print(f"{'A':>10} {'B':>10} {'B - A':>9}  (10^6 instructions, self)")
        print(f"{engine[0] / 1e6:10.1f} {engine[1] / 1e6:10.1f} {(engine[1] - engine[0]) / 1e6:+9.1f}  "
              f"all compiled code (numba), {engine[1] / engine[0] - 1:+.2%}")
        for k in sorted(set(a) | set(b), key=lambda k: -abs(b.get(k, 0) - a.get(k, 0)))[:25]:
            print(f"{a.get(k, 0) / 1e6:10.1f} {b.get(k, 0) / 1e6:10.1f} {(b.get(k, 0) - a.get(k, 0)) / 1e6:+9.1f}  {k}")
        return
    out = args.paths[0]
    env = dict(os.environ, NUMBA_CPU_NAME="generic", **({"PYTHONPATH": args.src} if args.src else {}))
    cmd = [sys.executable, __file__, "case", out, "--kind", args.mode]
    subprocess.run(cmd, env=env, check=True, capture_output=True)  # warm numba's cache outside valgrind
    run = subprocess.run(["valgrind", "--tool=callgrind", f"--callgrind-out-file={out}"] + cmd, env=env,
                         check=True, capture_output=True, text=True)
    print(run.stdout.strip())


if __name__ == "__main__":
    main()
