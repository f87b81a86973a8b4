"""Tiny checkpoints for the planner and evaluation tests: one epoch on synthetic episodes (the right inputs
and outputs, no skill), the grasp-only model and both tasks' TOG-Nets."""

from pathlib import Path


def tiny_models(root: Path, search: bool = False) -> dict[str, Path]:
    """``{"grasping": best.pt, <task>: best.pt}`` for every registered task, trained in a few seconds; with
    ``search``, also each task's action-conditioned model (``<task>_search``, task_head="action") that the
    learned action search needs."""
    from tognet.data.synthetic import write_synthetic_dataset
    from tognet.model.config import ArchConfig, TrainConfig
    from tognet.model.train import train

    arch = ArchConfig(stem_channels=8, block_channels=(8,), block_strides=(2,), bottleneck_channels=4,
                      z_features=8, head_hidden=16)
    cfg = TrainConfig(arch=arch, num_threads=1, epochs=1, batch_size=32, val_fraction=0.25, seed=0)
    out = {}
    from tognet.tasks import TASK_NAMES

    for task in ("grasping", *TASK_NAMES):
        data = write_synthetic_dataset(root / f"data-{task}", task=task, n=96, shard_size=96, seed=1,
                                       n_objects=8)
        out[task] = train([data], task, root / task, cfg, progress=False, log=lambda s: None).best_path
        if search and task != "grasping":
            import dataclasses

            action_arch = dataclasses.replace(arch, task_head="action", action_features=8, action_hidden=16)
            acfg = dataclasses.replace(cfg, arch=action_arch)
            out[f"{task}_search"] = train([data], task, root / f"{task}_search", acfg, progress=False,
                                          log=lambda s: None).best_path
    return out


def renderer_available() -> bool:
    """Whether MuJoCo's offscreen renderer starts here (EGL; `make system-deps` installs it)."""
    import os

    import mujoco

    from tognet.sim import SimConfig  # noqa: F401  (sets MUJOCO_GL before the renderer starts)

    try:
        mujoco.Renderer(mujoco.MjModel.from_xml_string("<mujoco/>"), 8, 8).close()
    except Exception:
        if os.environ.get("TOGNET_REQUIRE_GL") == "1":
            raise
        return False
    return True
