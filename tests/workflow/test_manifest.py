"""The experiment manifest: a manifest of another config is recognised, by its config hash."""

import json

from spherejam.workflow.experiment import config_hash
from spherejam.workflow.manifest import stale_manifest


def test_stale_manifest_names_the_hashes(tmp_path):
    manifest = tmp_path / "experiment.json"
    manifest.write_text(json.dumps({"config": {}, "config_hash": "0123456789abcdef"}))
    now = config_hash({"n": 1})
    assert stale_manifest(manifest, {"n": 1}) == f"config_hash 0123456789abcdef, the config's is {now}"
    assert stale_manifest(tmp_path / "none.json", {"n": 1}) is None
    manifest.write_text(json.dumps({"config": {}, "config_hash": now}))
    assert stale_manifest(manifest, {"n": 1}) is None
