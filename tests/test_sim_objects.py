"""Every task on primitive, complex and realistic objects made by the object generator."""

import numpy as np
import pytest

from tognet.objects.generate import generate_set
from tognet.sim import FailureReason, SimConfig, Simulator
from tognet.tasks import TASK_NAMES

KINDS = [("primitive", "train"), ("complex", "train"), ("realistic", "test")]


@pytest.fixture(scope="module")
def objects(tmp_path_factory):
    out = {}
    for kind, split in KINDS:
        out[kind] = generate_set(kind, split, 2, tmp_path_factory.mktemp(kind))
    return out


@pytest.mark.parametrize("task", [*TASK_NAMES, "grasping"])
@pytest.mark.parametrize("kind", [k for k, _ in KINDS])
def test_task_runs_on_generated_objects(objects, kind, task):
    for record in objects[kind]:
        sim = Simulator(SimConfig(), task, record)
        obs = sim.reset(11)
        assert obs.task == task and obs.object_id == record.object_id
        # The settled object is on the table, in the grasping half, and the camera sees it.
        com = sim.data.xipos[sim.object_body]
        assert com[0] < 0 and abs(com[1]) < 0.38 and com[2] > 0
        pts = obs.camera.deproject(obs.depth).reshape(-1, 3)
        assert np.sum(pts[:, 2] > 0.008) > 100
        res = sim.execute(
            sim.default_grasp(),
            None if task == "grasping" else sim.task.random_action(np.random.default_rng(0)),
            0,
        )
        assert isinstance(res.failure, FailureReason)
        assert res.valid, res.info
        if res.task_success:
            assert res.grasp_success and res.failure == FailureReason.NONE
        if not res.grasp_success:
            assert not res.task_success
