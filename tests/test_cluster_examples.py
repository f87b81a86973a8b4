"""The cluster files shipped in examples/cluster/ are valid for the Ray this project pins."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "examples" / "cluster"


def _pinned_ray() -> str:
    found = re.search(r'"ray==([0-9.]+)"', (ROOT / "pyproject.toml").read_text())
    assert found, "pyproject.toml pins no ray version"
    return found.group(1)


def test_the_ray_up_file_passes_rays_own_schema():
    yaml = pytest.importorskip("yaml")
    pytest.importorskip("ray")
    from ray.autoscaler._private.util import prepare_config, validate_config

    config = yaml.safe_load((EXAMPLES / "cluster.yaml").read_text())
    validate_config(prepare_config(config))
    assert any("--num-cpus=0" in c for c in config["head_start_ray_commands"])
    broken = dict(config, max_wokers=3)  # a misspelt key is refused: the check can fail
    with pytest.raises(Exception, match="max_wokers"):
        validate_config(prepare_config(broken))


def test_the_kuberay_file_names_the_pinned_ray_and_turns_tokens_on():
    yaml = pytest.importorskip("yaml")
    spec = yaml.safe_load((EXAMPLES / "kuberay.yaml").read_text())["spec"]
    assert spec["rayVersion"] == _pinned_ray()
    assert spec["authOptions"] == {"mode": "token"}
    assert spec["headGroupSpec"]["rayStartParams"]["num-cpus"] == "0"
    worker = spec["workerGroupSpecs"][0]["template"]["spec"]["containers"][0]
    assert {"name": "TOGNET_CACHE_DIR", "value": "/cache/tognet"} in worker["env"]
