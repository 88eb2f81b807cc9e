"""``spherejam run`` and ``spherejam init``: the workflow that ships in the package, from any folder.

``spherejam run`` is ``snakemake`` on the packaged Snakefile (:mod:`spherejam.workflow.packaged`) in the current
folder: the default experiment (``config/config.yaml`` of the package) or the ``--configfile`` given, its results in
the config's ``results`` folder or in ``-o`` (which then gets the config as run, ``run_config.yaml``). Options it does
not know go to Snakemake as they are (``-n``, targets, ``--forceall``, ``--profile``...). Snakemake takes its default
options from ``profiles/default/config.yaml`` of the current folder if there is one, else the package's (2 cores).

``spherejam init DIR`` writes an experiment folder to edit: ``config.yaml`` (a packaged config with its comments),
``profiles/default/config.yaml`` (the local profile) and ``powder.csv`` (the measured-PSD example the config's
comments name). ``cd DIR && spherejam run --configfile config.yaml`` then runs it.
"""

from __future__ import annotations

import subprocess
from pathlib import Path

from ..core.errors import InputError
from ..core.validation import FIELDS

#: What ``spherejam init`` writes, as (path in the folder, path in the packaged workflow).
INIT_FILES = (
    ("profiles/default/config.yaml", "profiles/default/config.yaml"),
    ("powder.csv", "examples/powder.csv"),
)


def register(sub) -> None:
    p = sub.add_parser(
        "run", allow_abbrev=False,  # "--config" is Snakemake's, not an abbreviation of --configfile
        help="run the packaged workflow in this folder (default experiment, or --configfile)",
        description="Runs the Snakemake workflow that ships with spherejam in the current folder. Options not listed "
        "here go to snakemake unchanged (e.g. -n for a dry run, a target file, --forceall).")
    p.add_argument("--configfile", type=Path, default=None,
                   help="the experiment (default: the package's config/config.yaml; `spherejam init` writes one to "
                   "edit)")
    p.add_argument("-o", "--results", default=None,
                   help="results folder (default: the config's `results`, relative to this folder)")
    p.add_argument("--cores", type=FIELDS["calippso.threads"].arg, default=None,
                   help="cores for the workflow (default: the profile's, 2)")
    p.set_defaults(func=_run, passthrough=True)

    p = sub.add_parser("init", help="write an experiment folder to edit (config with comments, profile)",
                       description="Writes DIR/config.yaml (a packaged experiment with its comments), "
                       "DIR/profiles/default/config.yaml and DIR/powder.csv. Then: cd DIR && spherejam run "
                       "--configfile config.yaml.")
    p.add_argument("directory", type=Path, metavar="DIR")
    p.add_argument("--from", dest="template", default="config", metavar="NAME",
                   help="the packaged config to start from: config (default experiment), tiny, psd, reproduction or "
                   "paper")
    p.set_defaults(func=_init)


#: With -o, the config as run (the given one with ``results`` replaced) is written into the results folder as this.
RUN_CONFIG = "run_config.yaml"


def run_arguments(args, extra: list[str]) -> list[str]:
    """Snakemake's arguments for ``spherejam run``: the packaged Snakefile, the config, the options given.

    With ``-o`` the config is copied into that folder with ``results`` replaced, and the copy is run (Snakemake's
    ``--config results=...`` would read a folder named ``1e3`` as the number 1000)."""
    from ..workflow import packaged

    config = args.configfile if args.configfile is not None else packaged.config_file("config")
    if not config.is_file():
        raise InputError(f"--configfile={str(config)!r}: no such file")
    if args.results is not None:
        config = _config_with_results(config, args.results)
    out = ["--snakefile", str(packaged.snakefile()), "--configfile", str(config.resolve())]
    if args.cores is not None:
        out += ["--cores", str(args.cores)]
    return out + list(extra)


def _config_with_results(config: Path, results: str) -> Path:
    import yaml

    from ..core.atomic import atomic_output
    from ..workflow.config import load_config_file

    if results.strip() == "":
        raise InputError(f"-o/--results={results!r}: an empty path")
    data = load_config_file(config)
    if not isinstance(data, dict):
        raise InputError(f"--configfile={str(config)!r}: not a mapping of config keys")
    data["results"] = results
    target = Path(results) / RUN_CONFIG
    if target.exists() and target.resolve() == config.resolve():  # run again from its own copy: nothing to write
        return config
    target.parent.mkdir(parents=True, exist_ok=True)
    with atomic_output(target, ".yaml") as tmp:
        Path(tmp).write_text(f"# spherejam run: {config.resolve()} with results: {results}\n"
                             + yaml.safe_dump(data, sort_keys=False))
    return target


def _run(args) -> int:
    from ..workflow.packaged import snakemake_command

    cmd, env = snakemake_command()
    return subprocess.run([*cmd, *run_arguments(args, getattr(args, "extra", []))], env=env).returncode


def _init(args) -> int:
    from ..core.atomic import atomic_output
    from ..workflow import packaged

    names = packaged.experiment_names()
    if args.template not in names:
        raise InputError(f"--from={args.template!r}: must be one of {', '.join(names)}")
    folder = args.directory
    if folder.exists() and not folder.is_dir():
        raise InputError(f"DIR={str(folder)!r}: exists and is not a directory")
    files = [("config.yaml", packaged.config_file(args.template)),
             *((name, packaged.workflow_dir() / source) for name, source in INIT_FILES)]
    present = [name for name, _ in files if (folder / name).exists()]
    if present:  # an edited experiment is never overwritten
        raise InputError(f"DIR={str(folder)!r}: already holds {present[0]} (choose a new folder)")
    header = (f"# A spherejam experiment, from the package's config/{args.template}.yaml. Edit it, then run it from "
              "this folder:\n#   spherejam run --configfile config.yaml          (add -n to see what it would run)\n"
              "# The results go to the `results` folder below, relative to this folder. Every key is described in\n"
              "# the package's config/schema.yaml; a --configfile is the whole experiment (nothing is merged in).\n")
    for name, source in files:
        target = folder / name
        target.parent.mkdir(parents=True, exist_ok=True)
        text = source.read_text()
        with atomic_output(target, target.suffix) as tmp:
            Path(tmp).write_text(header + text if name == "config.yaml" else text)
        print(target)
    return 0
