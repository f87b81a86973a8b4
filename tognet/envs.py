"""Gymnasium environments: one step = one episode (observe the depth image, act once, get the labels).

Registered on ``import tognet.envs``:

- ``tognet/<Task>-v0`` for every registered task (Sweeping, Hammering, Pulling): action = grasp (x, y, z,
  phi) + motion (a_x, a_y, a_z, a_phi), 8 numbers; reward = 1.0 when the task succeeds.
- ``tognet/Grasping-v0``: action = grasp only (4 numbers); reward = 1.0 when the tool is lifted clear.

Actions are float32. With ``normalize_actions=True`` the action box is [-1, 1] in every dimension and is
mapped linearly onto the physical box (metres, radians) before execution, the layout most RL libraries
expect (Stable-Baselines3's checker warns on unnormalised boxes); ``info['action']`` always holds the
physical action that ran.

Observation: ``depth`` (H, W) float32 metres with holes as 0.0 (gymnasium boxes cannot hold NaN),
``intrinsics`` (fx, fy, cx, cy), ``camera_pose`` (4x4 world_from_camera) and ``reference`` (the task's
reference point). ``info`` carries the labels (grasp_success, task_success, valid), the failure reason, the
object id and the scene seed. Objects come from ``objects=<set folder>``; without it, the hand-made T hammer
and L tool are used.
"""

from __future__ import annotations

import tempfile
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from tognet.geometry import Grasp
from tognet.objects.handmade import make_test_tools
from tognet.objects.record import ObjectRecord, load_catalog
from tognet.sim import Observation, SimConfig, Simulator
from tognet.tasks import DEFAULT_TASK, GRASP_ONLY, SIM_TASKS, get_task

#: Gymnasium id of each registered task's env (``tognet/<Task>-v0``) and of grasping only.
ENV_IDS = {name: f"tognet/{name.capitalize()}-v0" for name in SIM_TASKS}


class TognetEnv(gym.Env):
    """One tool-use episode per step (see the module docstring)."""

    metadata = {"render_modes": []}

    def __init__(
        self,
        task: str = DEFAULT_TASK,
        objects: str | Path | None = None,
        config: SimConfig | None = None,
        max_cached: int = 8,
        normalize_actions: bool = False,
    ) -> None:
        self.task_name = task
        self.normalize_actions = normalize_actions
        self.config = config or SimConfig()
        self._tmp: tempfile.TemporaryDirectory[str] | None = None
        if objects is None:
            self._tmp = tempfile.TemporaryDirectory(prefix="tognet_tools_")
            self.records: list[ObjectRecord] = list(make_test_tools(self._tmp.name).values())
        else:
            self.records = load_catalog(objects)
        if not self.records:
            raise ValueError(f"no objects in {objects}")
        self._sims: dict[str, Simulator] = {}
        self._max_cached = max_cached
        self._sim: Simulator | None = None
        self._obs: Observation | None = None
        c = self.config.camera
        w = self.config.world
        lx, ly = 0.5 * w.table_size[0], 0.5 * w.table_size[1]
        self.observation_space = spaces.Dict(
            {
                # Finite bounds: depth in metres (0 = hole; the Kinect2 reads to ~8 m), focal lengths and
                # principal point in pixels, poses and points in metres around the table (world origin).
                "depth": spaces.Box(0.0, 10.0, shape=(c.height, c.width), dtype=np.float32),
                "intrinsics": spaces.Box(0.0, 1e4, shape=(4,), dtype=np.float64),
                "camera_pose": spaces.Box(-10.0, 10.0, shape=(4, 4), dtype=np.float64),
                "reference": spaces.Box(-10.0, 10.0, shape=(3,), dtype=np.float64),
            }
        )
        grasp_low = np.array([-lx, -ly, 0.0, 0.0])
        grasp_high = np.array([lx, ly, 0.3, 2 * np.pi])
        if task == GRASP_ONLY:
            low, high = grasp_low, grasp_high
        else:
            t = get_task(task, self.config.task_config(task))
            low = np.concatenate([grasp_low, t.action_low])
            high = np.concatenate([grasp_high, t.action_high])
        # The physical box (float64, used to map normalised actions); the space itself is float32.
        self.action_low = np.asarray(low, dtype=np.float64)
        self.action_high = np.asarray(high, dtype=np.float64)
        if normalize_actions:
            ones = np.ones(len(low), dtype=np.float32)
            self.action_space = spaces.Box(-ones, ones, dtype=np.float32)
        else:
            self.action_space = spaces.Box(
                self.action_low.astype(np.float32), self.action_high.astype(np.float32), dtype=np.float32
            )

    def physical_action(self, action: np.ndarray) -> np.ndarray:
        """The action in metres and radians (float64): unchanged, or mapped from [-1, 1] when normalised."""
        a = np.asarray(action, dtype=np.float64).reshape(-1)
        if a.shape != self.action_space.shape:
            raise ValueError(f"action must have shape {self.action_space.shape}, got {a.shape}")
        if not np.all(np.isfinite(a)):
            raise ValueError(f"action has non-finite values: {a.tolist()}")
        if self.normalize_actions:
            a = self.action_low + 0.5 * (np.clip(a, -1.0, 1.0) + 1.0) * (self.action_high - self.action_low)
        return a

    def _simulator(self, record: ObjectRecord) -> Simulator:
        sim = self._sims.get(record.object_id)
        if sim is None:
            if len(self._sims) >= self._max_cached:
                self._sims.pop(next(iter(self._sims)))
            sim = Simulator(self.config, self.task_name, record)
            self._sims[record.object_id] = sim
        return sim

    def _observation(self, obs: Observation) -> dict[str, np.ndarray]:
        k = obs.camera.intrinsics
        return {
            "depth": np.nan_to_num(obs.depth, nan=0.0).astype(np.float32),
            "intrinsics": np.array([k.fx, k.fy, k.cx, k.cy]),
            "camera_pose": obs.camera.pose.copy(),
            "reference": np.asarray(obs.reference, dtype=np.float64).copy(),
        }

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        """A new scene: a random object (or ``options['object_id']``) dropped with a random scene seed."""
        super().reset(seed=seed)
        options = options or {}
        if "object_id" in options:
            matches = [r for r in self.records if r.object_id == options["object_id"]]
            if not matches:
                raise ValueError(f"no object '{options['object_id']}' in this environment's set")
            record = matches[0]
        else:
            record = self.records[int(self.np_random.integers(len(self.records)))]
        scene_seed = int(options.get("scene_seed", self.np_random.integers(2**31 - 1)))
        self._sim = self._simulator(record)
        self._obs = self._sim.reset(scene_seed)
        info = {"object_id": record.object_id, "scene_seed": scene_seed, "camera": self._obs.camera.to_dict()}
        return self._observation(self._obs), info

    def step(self, action: np.ndarray) -> tuple[dict[str, np.ndarray], float, bool, bool, dict[str, Any]]:
        """Execute the grasp (and motion); one step ends the episode."""
        if self._sim is None or self._obs is None:
            raise RuntimeError("call reset() before step()")
        a = self.physical_action(action)
        grasp = Grasp.from_array(a[:4])
        motion = a[4:] if self.task_name != GRASP_ONLY else None
        trial_seed = int(self.np_random.integers(2**31 - 1))
        result = self._sim.execute(grasp, motion, trial_seed)
        success = result.grasp_success if self.task_name == GRASP_ONLY else result.task_success
        info = {
            "grasp_success": result.grasp_success,
            "task_success": result.task_success,
            "valid": result.valid,
            "failure": result.failure.value,
            "object_id": self._obs.object_id,
            "scene_seed": self._obs.seed,
            "trial_seed": trial_seed,
            "action": a,
            **result.info,
        }
        return self._observation(self._obs), float(success), True, False, info

    def close(self) -> None:
        """Drop the simulators and the temporary tool folder."""
        self._sims.clear()
        if self._tmp is not None:
            self._tmp.cleanup()
            self._tmp = None


def _register() -> None:
    for task, env_id in ENV_IDS.items():
        if env_id not in gym.registry:
            gym.register(id=env_id, entry_point="tognet.envs:TognetEnv", kwargs={"task": task})


_register()
