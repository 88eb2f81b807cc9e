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
