"""``spherejam rcp SPEC ...``: one command from a particle-size distribution to phi_LT and phi_RCP (docs/psd.md).

It fills the workflow template ``config/psd.yaml`` (of the workflow packaged with spherejam, or ``--workflow``) with
the distributions and sizes given, writes it into the results folder, prints the cost estimate, runs the workflow
(``snakemake``, as a separate program: the package does not import it) with its live progress, and prints phi_LT and
phi_RCP with their intervals beside the three published models. The workflow writes the usual dataset, tables and
Fig. 5; running the command again resumes where it stopped. It runs in the current folder (Snakemake's
``.snakemake/`` goes there; relative ``table:`` files are read from there).

With ``--container SPEC`` (docs/containers.md) the same experiment runs twice, in the container and in the periodic
cube (``bulk``), as the workflow's container axis: phi_LT and phi_RCP are printed in both, with their intervals, and
the figures of φ against D/d and of the porosity profile are drawn too.
"""

from __future__ import annotations

import math
import re
import subprocess
import sys
from pathlib import Path

from ..core.errors import InputError, SpherejamError
from ..core.output_paths import check_output_dir
from ..core.validation import FIELDS
from . import seed_int

TEMPLATE = Path("config") / "psd.yaml"  # of the workflow folder
_NAME = re.compile(r"^([A-Za-z][A-Za-z0-9_-]*)=(.+)$")


def register(sub) -> None:
    p = sub.add_parser("rcp", help="one command from size distributions to phi_LT, phi_RCP and the models "
                       "(docs/psd.md)",
                       description="Runs the workflow template config/psd.yaml (fast LS and FB compressions, each "
                       "followed by MLS and CALiPPSO) for the distributions given and prints phi_LT and phi_RCP with "
                       "their intervals beside the Farr-Groot, Desmond-Weeks and Santos et al. models. Runs from any "
                       "folder: the workflow ships in the package.")
    p.add_argument("specs", nargs="+", metavar="[NAME=]SPEC",
                   help="size distributions, e.g. powder=table:examples/powder.csv gauss=gaussian:delta=0.2")
    p.add_argument("--n", type=FIELDS["n"].arg, default=None, help="spheres per packing (template: 200)")
    p.add_argument("--replicas", type=FIELDS["replicas"].arg, default=None,
                   help="packings per rate and protocol (template: 2, i.e. 10 LS + 10 FB per distribution)")
    p.add_argument("--seed", type=seed_int, default=None, help="master seed (template: 2014)")
    p.add_argument("--container", metavar="SPEC", action="append", default=None,
                   help="also run the experiment in this container (docs/containers.md), e.g. cylinder:diameter=10; "
                        "phi_LT and phi_RCP are printed in it and in bulk (the periodic cube); may be repeated")
    p.add_argument("-o", "--results", type=Path, default=Path("results") / "psd", help="results folder")
    p.add_argument("--cores", type=FIELDS["calippso.threads"].arg, default=2, help="cores for the workflow (2)")
    p.add_argument("--workflow", type=Path, default=None,
                   help="a folder with the Snakefile, rules/ and config/ (default: the workflow packaged with "
                   "spherejam)")
    p.add_argument("--template", type=Path, default=None,
                   help=f"the workflow config to fill in (default: {TEMPLATE} of the workflow)")
    p.add_argument("--dry-run", action="store_true", help="print the config and the cost estimate only")
    p.set_defaults(func=_rcp)


def named_specs(items: list[str]) -> dict[str, str]:
    """``NAME=SPEC`` or ``SPEC`` (named after its file stem or family) -> {name: spec}, names unique."""
    out: dict[str, str] = {}
    for item in items:
        m = _NAME.match(item)
        if m and ":" not in m.group(1):
            name, spec = m.group(1), m.group(2)
        else:
            family, _, rest = item.partition(":")
            base = Path(rest).stem if family in ("table", "list") else re.sub(r"[^A-Za-z0-9]+", "-", item).strip("-")
            name = re.sub(r"[^A-Za-z0-9_-]", "-", base) or family
            if not name[0].isalpha():
                name = f"{family}-{name}"
            spec = item
        if name in out:
            raise InputError(f"{item!r}: the name {name!r} is given twice (write NAME=SPEC)")
        out[name] = spec
    return out


def workflow_folder(args) -> Path:
    """The workflow ``--workflow`` names, or the one packaged with spherejam."""
    from ..workflow.packaged import workflow_dir

    return workflow_dir() if args.workflow is None else args.workflow


def build_config(args) -> dict:
    from ..core.size_distribution import parse
    from ..workflow.config import load_config_file

    workflow = workflow_folder(args)
    template = args.template or workflow / TEMPLATE
    if not (workflow / "Snakefile").is_file():
        raise InputError(f"--workflow={str(workflow)!r}: no Snakefile there (give a folder holding the Snakefile, "
                         "rules/ and config/, or leave --workflow out for the packaged workflow)")
    config = load_config_file(template, "--template", empty_ok=False)  # the loader `spherejam cost` uses
    dists = named_specs(args.specs)
    for name, spec in dists.items():
        parse(spec, name)  # a bad spec or file: one line, before anything is written
    config["distributions"] = dists
    config["results"] = str(args.results.resolve())
    for key in ("n", "replicas", "seed"):
        if getattr(args, key) is not None:
            config[key] = getattr(args, key)
    if getattr(args, "container", None):
        config["containers"] = named_containers(args.container)
    return config


def named_containers(specs: list[str]) -> dict[str, str]:
    """``{bulk: periodic, <name>: spec, ...}`` for the ``--container`` specs, each named after its spec
    (``cylinder-diameter-10``); a bad spec is one line naming it."""
    from ..core.container import parse

    out = {"bulk": "periodic"}
    for spec in specs:
        text = parse(spec, "--container").text
        if text == "periodic":
            continue  # the bulk is always there
        name = re.sub(r"[^A-Za-z0-9]+", "-", text.replace(".0,", ",").removesuffix(".0")).strip("-")
        if name in out:
            raise InputError(f"--container={spec!r}: given twice")
        out[name] = text
    return out


def _rcp(args) -> int:
    import yaml

    from ..core.atomic import atomic_output
    from ..workflow.config import validate_config
    from ..workflow.cost_model import plan, print_plan
    from ..workflow.experiment import Experiment
    from ..workflow.packaged import snakemake_command

    check_output_dir("-o/--results", args.results)  # a file there: one line naming the option, before any work
    config = build_config(args)
    workflow = workflow_folder(args)
    validate_config(config, workflow / "config" / "schema.yaml")
    exp = Experiment(config)
    cells = len(exp.distributions) * len(exp.container_keys)
    where = (f" in {len(exp.containers)} containers ({', '.join(f'{c.key}: {c.spec}' for c in exp.containers)})"
             if exp.has_containers else "")
    print(f"spherejam rcp: N = {exp.largest_n}, {len(exp.runs())} packings ({len(exp.distributions)} distributions"
          f"{where}, {len(exp.runs()) // max(cells, 1)} packings each: fast LS and FB, each then MLS and "
          f"CALiPPSO), results in {exp.results}")
    for c in exp.containers:
        if not c.is_periodic_cube:
            _describe_container(exp, c)
    print("cost estimate (the cost model, docs/cluster.md):")
    print_plan(config)
    cpu_h = sum(r["cpu_hours"] for table in plan(config).values() for r in table.values())
    print(f"about {cpu_h * 60:.2g} CPU-minutes, {cpu_h * 60 / args.cores:.2g} min on {args.cores} cores (an idle "
          "machine)")
    if args.dry_run:
        print(yaml.safe_dump(config, sort_keys=False))
        return 0
    cfg_path = exp.results / "config.yaml"
    cfg_path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_output(cfg_path, ".yaml") as tmp:
        Path(tmp).write_text(yaml.safe_dump(config, sort_keys=False))
    targets = [exp.paths.dataset, *exp.paths.tables(["csv", "md"]), exp.paths.figure("png", "fig5")]
    if exp.has_containers:
        targets += [exp.paths.figure("png", name) for name in ("containers", "profiles")]
    log = exp.results / "logs" / "rcp-snakemake.log"
    log.parent.mkdir(parents=True, exist_ok=True)
    snakemake, env = snakemake_command()
    cmd = [*snakemake, "--cores", str(args.cores), "--configfile", str(cfg_path.resolve()), "--snakefile",
           str((workflow / "Snakefile").resolve()), "--rerun-incomplete", "--keep-going", *targets]
    print(f"running: {' '.join(cmd)}  (full log: {log})", flush=True)
    with open(log, "w") as fh:
        proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=env)
        for line in proc.stdout:  # live progress: the workflow's step counter and any error
            fh.write(line)
            fh.flush()
            if re.search(r"steps \(\d+%\) done|Error|error|Nothing to be done", line):
                print(f"  {line.rstrip()}", flush=True)
        code = proc.wait()
    if code != 0:
        for line in failed_jobs(log):
            print(f"  failed: {line}", flush=True)
        raise SpherejamError(f"the workflow failed (exit {code}); see {log} and the job logs in {exp.results}/logs")
    print_summary(exp.paths.table("table4", "csv"), exp.paths.table("table3", "csv"))
    return 0


#: A periodic length (mean diameters) below which a container's periodic images lie close enough to order it.
SHORT_PERIOD = 5.0


def _describe_container(exp, entry) -> None:
    """The container's lengths at the experiment's N before jamming (the achieved ones are in the dataset), and a
    warning for a periodic length so short that a sphere meets its own images a few diameters away."""
    import numpy as np

    from ..core.container import PHI_ESTIMATE, build

    d = exp.distributions[0]
    run = next(r for r in exp.runs() if r.container == entry.key and r.dist == d.key)
    model = d.model()
    n = exp.size(run)
    c = build(entry.model(), n, model.draw(model.fixed_n or n, np.random.default_rng(0)))
    sizes = ", ".join(f"{k} = {v:.3g}" for k, v in c.in_diameters(1.0).items())
    print(f"  {entry.key}: N = {n}, {sizes} mean diameters (sized for phi = {PHI_ESTIMATE}; the achieved D/<d> "
          "is reported)")
    short = [k for k in range(c.dim) if c.periodic[k] and c.lengths[k] < SHORT_PERIOD]
    if short:
        print(f"  {entry.key}: warning: periodic along {'xyz'[short[0]]} over only {c.lengths[short[0]]:.3g} mean "
              "diameters; give a larger --n (or the container's length) for a longer column")


def failed_jobs(log: Path) -> list[str]:
    """``job log: its last line`` for every job the workflow log reports as failed (the job's one-line error)."""
    text = Path(log).read_text(errors="replace")
    out = []
    for block in text.split("Error in rule ")[1:]:
        m = re.search(r"^\s*log: (\S+)", block, re.M)
        if m and Path(m.group(1)).is_file():
            lines = [x for x in Path(m.group(1)).read_text(errors="replace").splitlines() if x.strip()]
            out.append(f"{m.group(1)}: {lines[-1] if lines else '(empty log)'}")
    return out


def _interval(value: float, half: float, n: str) -> str:
    if not math.isfinite(value):
        return f"not estimable ({n})"
    ci = f" ± {half:.4f}" if math.isfinite(half) else f", CI not estimable ({n})"
    return f"{value:.4f}{ci}"


def print_summary(table4: str | Path, table3: str | Path, out=None) -> None:
    """phi_LT and phi_RCP per distribution with their intervals, beside the three models (from the tables)."""
    import pandas as pd

    from ..workflow.tables import MODELS

    out = out or sys.stdout
    t4, t3 = pd.read_csv(table4), pd.read_csv(table3)
    key = "distribution" if "distribution" in t4 else "sigma"
    bulk = {}  # per distribution: the periodic cube's row, beside which a container's is printed
    if "container" in t4:
        bulk = {r[key]: r for _, r in t4[t4.container_spec == "periodic"].iterrows()}
    for (_, r4), (_, r3) in zip(t4.iterrows(), t3.iterrows()):
        n = f"n = {int(r3.ls_n_fast)} LS + {int(r3.fb_n_fast)} FB fast packings"
        label = r4[key] if key == "distribution" else f"sigma = {r4.sigma:g}"
        where = f"in {r4.container} ({r4.container_spec}): " if "container" in r4 else ""
        print(f"{where}{label} ({r4.psd if 'psd' in r4 else ''})", file=out)
        print(f"  φ_LT  = {_interval(r4.phi_LT, r4.phi_LT_half_width, n)}", file=out)
        print(f"  φ_RCP = {_interval(r4.phi_RCP, r4.phi_RCP_half_width, n)}", file=out)
        if "container" in r4 and r4.container_spec != "periodic":  # the models are of the bulk
            ref = bulk.get(r4[key])
            if ref is not None:
                diffs = [r4[c] - ref[c] for c in ("phi_LT", "phi_RCP")]
                text = [f"{x:+.4f}" if math.isfinite(x) else "not estimable" for x in diffs]
                print(f"  container − bulk ({ref.container}): φ_LT {text[0]}, φ_RCP {text[1]}", file=out)
            continue
        models = "   ".join(f"{label_}: {r4[f'model_{m}']:.4f} (ours − model {r4[f'phi_RCP_minus_{m}']:+.4f})"
                            for m, label_ in MODELS.items())
        print(f"  models: {models}", file=out)
