"""The simulator core names no task: each task hands it its props through the registry, and its config
sections come from the registry too, while a SimConfig saved in the old layout still loads."""

import json
import re
from pathlib import Path

import numpy as np
import pytest

import tognet.sim
from tognet.sim import SimConfig
from tognet.tasks import TASK_NAMES, task_config_class

SIM_DIR = Path(tognet.sim.__file__).parent
MODELS = Path(tognet.sim.__file__).parent.parent / "models"


@pytest.mark.parametrize("path", sorted([*SIM_DIR.rglob("*.py"), *(SIM_DIR.parent / "robot").rglob("*.py")]),
                         ids=lambda p: str(p.relative_to(SIM_DIR.parent)))
def test_no_sim_module_names_a_task(path):
    text = path.read_text()
    for name in TASK_NAMES:
        hits = [i + 1 for i, line in enumerate(text.splitlines()) if re.search(name, line, re.IGNORECASE)]
        assert not hits, f"{path.name} names the task {name!r} on line(s) {hits}"


def test_sim_config_has_a_section_per_registered_task():
    cfg = SimConfig()
    assert list(cfg.tasks) == list(TASK_NAMES)
    for name in TASK_NAMES:
        assert isinstance(cfg.task_config(name), task_config_class(name))
        assert cfg.task_config(name) is getattr(cfg, name)
    assert list(cfg.to_dict()) == ["physics", "world", "camera", "gripper", "episode", "robot", *TASK_NAMES]
    with pytest.raises(ValueError, match="unknown task"):
        cfg.task_config("juggling")


def _saved_sim_config(model: str) -> dict:
    """The SimConfig saved with a shipped model (its collection preset's ``sim`` section)."""
    return json.loads((MODELS / f"{model}.json").read_text())["preset"]["collect"]["sim"]


@pytest.mark.parametrize("model", ["hammering", "sweeping", "pulling"])
def test_a_sim_config_saved_in_the_old_layout_loads_and_round_trips(model, tmp_path):
    saved = _saved_sim_config(model)
    cfg = SimConfig.from_dict(saved)
    # The same sections, keys and values, in the same order; a section added after the model was saved
    # (the robot, a task registered later such as pulling) comes with its defaults, in its place.
    added = [name for name in TASK_NAMES if name not in saved]
    assert {k: v for k, v in cfg.to_dict().items() if k in saved} == saved
    assert [k for k in cfg.to_dict() if k in saved] == list(saved)
    assert set(cfg.to_dict()) - set(saved) <= {"robot", *added}
    assert cfg.robot.name == "floating"  # a model's world without a robot section is the floating gripper
    for name in added:
        assert cfg.task_config(name) == task_config_class(name)()
    path = cfg.save(tmp_path / "sim.json")
    again = SimConfig.load(path)
    assert again == cfg
    on_disk = json.loads(path.read_text())
    assert on_disk.pop("config_type") == "SimConfig"
    assert {k: v for k, v in on_disk.items() if k in saved} == saved
    # A changed task section travels the same way.
    for name in TASK_NAMES:
        section = cfg.task_config(name)
        assert SimConfig.from_dict(cfg.replace(**{name: section}).to_dict()) == cfg


@pytest.mark.parametrize("task", TASK_NAMES)
def test_every_registered_task_hands_the_simulator_its_props(task, tools):
    from tognet.sim import Simulator
    from tognet.tasks import get_props, get_task
    from tognet.tasks.props import TaskProps

    props = get_props(get_task(task))
    assert type(props) is not TaskProps  # a task's own props, not the empty set
    assert props.check_object in tools and set(props.outcome_keys)
    sim = Simulator(SimConfig(), task, tools[props.check_object])
    assert type(sim.props) is type(props)
    mjcf = sim.props.mjcf(sim.config, 4)
    assert mjcf.target_geoms and mjcf.touch_bodies
    sim.reset(1)
    assert len(sim.props.positions()) >= 1
    result = sim.execute(sim.default_grasp(), np.zeros(4), seed=0)
    assert result.valid


def test_grasping_has_no_props(tools):
    from tognet.sim import Simulator

    sim = Simulator(SimConfig(), "grasping", tools["t_hammer"])
    sim.reset(0)
    assert len(sim.props.positions()) == 0 and not sim.props.near()
