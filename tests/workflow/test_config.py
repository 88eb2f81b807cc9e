"""The config check (workflow/config.py): config keys that reach the rules and the cluster resources."""

import pytest

from spherejam.core.errors import InputError


@pytest.mark.parametrize("bad", [0, 2.5, 257, "two"])
def test_threads_config_key_is_validated(bad):
    """calippso.threads reaches the rule (``--threads``, the rule's cores, cpus_per_task); a bad value is one line
    naming calippso.threads, from the schema and from check_config alike."""
    from pathlib import Path

    import yaml

    from spherejam.workflow.config import check_config, validate_config
    from spherejam.workflow.cost_model import cpus_per_task, job_resources
    from spherejam.workflow.experiment import Experiment

    root = Path(__file__).resolve().parents[2]
    config = yaml.safe_load((root / "config" / "tiny.yaml").read_text())
    config["calippso"]["threads"] = 2
    exp = Experiment(validate_config(config, root / "config" / "schema.yaml"))
    assert exp.calippso_threads == 2
    assert job_resources("calippso", exp.largest_n, threads=exp.calippso_threads)["cpus_per_task"] == 2
    assert cpus_per_task("mls") == 1 and cpus_per_task("calippso") == 1
    config["calippso"]["threads"] = bad
    for check in (lambda c: validate_config(c, root / "config" / "schema.yaml"), check_config):
        with pytest.raises(InputError, match=r"calippso\.threads=") as info:
            check(config)
        assert "\n" not in str(info.value)
    with pytest.raises(InputError, match=r"calippso\.threads="):
        cpus_per_task("calippso", bad)


def test_calippso_interior_steps_forces_the_lp_path_and_its_price(tmp_path, capsys):
    """calippso.interior_steps: true or false becomes the rule's flag and the cost model's LP path; absent or null
    the package chooses by N (docs/calippso.md §10.11); anything else is one line naming the field (exit 2)."""
    from pathlib import Path

    import yaml

    from spherejam.core.calippso_path import interior_steps_at
    from spherejam.workflow.config import validate_config
    from spherejam.workflow.cost_model import plan
    from spherejam.workflow.experiment import Experiment

    root = Path(__file__).resolve().parents[2]
    schema = root / "config" / "schema.yaml"
    config = yaml.safe_load((root / "config" / "tiny.yaml").read_text())
    hours = {}
    for value, flag in ((None, ""), (True, "--interior-steps"), (False, "--no-interior-steps")):
        config["calippso"] = {"enabled": True, "threads": 1, "interior_steps": value}
        exp = Experiment(validate_config(yaml.safe_load(yaml.safe_dump(config)), schema))
        assert exp.calippso_interior_steps is value and exp.calippso_options() == flag
        [table] = plan(exp.config).values()
        hours[value] = table["calippso"]["cpu_hours"]
    # tiny's N is below the threshold: the default prices the vertex path, a forced path its own
    assert not interior_steps_at(max(exp.sizes))
    assert hours[None] == pytest.approx(hours[False]) and hours[True] != pytest.approx(hours[False])
    _bad_calippso_values_are_one_line(config, "interior_steps", ("maybe", 1, 0.5), schema, tmp_path, capsys)


def _bad_calippso_values_are_one_line(config, field, bads, schema, tmp_path, capsys):
    """Each bad value of calippso.<field>: one line naming the field from the schema and from check_config, and
    exit 2 with one line on stderr from `spherejam cost`."""
    import yaml

    from spherejam.cli import main
    from spherejam.workflow.config import check_config, validate_config

    for bad in bads:
        config["calippso"][field] = bad
        for check in (lambda c: validate_config(c, schema), check_config):
            with pytest.raises(InputError, match=rf"calippso\.{field}=") as info:
                check(yaml.safe_load(yaml.safe_dump(config)))
            assert "\n" not in str(info.value)
        (tmp_path / "bad.yaml").write_text(yaml.safe_dump(config))
        assert main(["cost", str(tmp_path / "bad.yaml")]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and f"calippso.{field}" in err[0]


def test_calippso_per_cell_certifies_a_fixed_sample_and_prices_only_it(tmp_path, capsys):
    """calippso.per_cell: k certifies k packings of each cell (N, container, distribution), the same ones for the
    same config; the dataset inputs and `spherejam cost` hold only them; a bad value is one line naming the field
    (exit 2 from the CLI)."""
    from pathlib import Path

    import yaml

    from spherejam.workflow.config import validate_config
    from spherejam.workflow.cost_model import plan
    from spherejam.workflow.experiment import Experiment

    root = Path(__file__).resolve().parents[2]
    schema = root / "config" / "schema.yaml"
    config = yaml.safe_load((root / "config" / "tiny.yaml").read_text())
    every = Experiment(validate_config(dict(config), schema))
    config["calippso"] = {"enabled": True, "threads": 1, "per_cell": 2}
    exp = Experiment(validate_config(yaml.safe_load(yaml.safe_dump(config)), schema))
    sample = [r for r in exp.runs() if exp.certifies(r)]
    cells = {(r.n, r.container, r.dist) for r in exp.runs()}
    assert len(cells) == 2 and len(sample) == 2 * len(cells) < len(exp.runs())
    assert all(sum((r.n, r.container, r.dist) == c for r in sample) == 2 for c in cells)
    again = Experiment(validate_config(yaml.safe_load(yaml.safe_dump(config)), schema))
    assert {r.key for r in again.runs() if again.certifies(r)} == {r.key for r in sample}
    # another seed draws another sample (the choice is the seed's, not the order of the runs)
    other = Experiment(validate_config({**yaml.safe_load(yaml.safe_dump(config)), "seed": 8}, schema))
    assert {r.key for r in other.runs() if other.certifies(r)} != {r.key for r in sample}
    certified = {f for f in exp.dataset_inputs() if f.endswith("calippso.json")}
    assert certified == {exp.paths.packing("calippso", r.key) for r in sample}
    [full], [part] = plan(every.config).values(), plan(exp.config).values()
    assert full["calippso"]["jobs"] == len(every.runs()) and part["calippso"]["jobs"] == len(sample)
    assert part["calippso"]["cpu_hours"] == pytest.approx(full["calippso"]["cpu_hours"] * len(sample)
                                                          / len(every.runs()))
    _bad_calippso_values_are_one_line(config, "per_cell", (0, 2.5, "two", -1), schema, tmp_path, capsys)
