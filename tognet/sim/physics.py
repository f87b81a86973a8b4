"""The physics core of the simulator: stepping, contacts by geom category, stability, saved states and
the world without props.

:class:`PhysicsCore` is a part of :class:`tognet.sim.simulator.Simulator` (it reads the attributes the
simulator's constructor sets: ``model``, ``data``, ``_cat``, ``_props``, ...). Every physics step of a
trial goes through :meth:`PhysicsCore._step`.
"""

from __future__ import annotations

import math
import time
from typing import Any

import mujoco
import numpy as np
from numpy.typing import NDArray

from tognet.errors import TognetError

# Geom categories used to read contacts quickly: the task's props are TARGET (what its primitive must hit)
# or PROP (the rest).
OTHER, TABLE, GROUND, OBJECT, FINGER_L, FINGER_R, GRIPPER, TARGET, PROP = range(9)
N_CATEGORIES = 9
TOOL_SIDE = np.isin(np.arange(N_CATEGORIES), (OBJECT, FINGER_L, FINGER_R, GRIPPER))  # the tool or the hand
HAND = np.isin(np.arange(N_CATEGORIES), (FINGER_L, FINGER_R, GRIPPER))
IS_TARGET = np.arange(N_CATEGORIES) == TARGET


class SimulationError(TognetError):
    """The world cannot be built or an episode cannot be set up (bad object, bad input)."""


class Unstable(Exception):
    """The physics blew up (NaN, a joint too fast, a contact too deep): the trial is invalid."""


class Landed(Exception):
    """The gripper landed on the object on its way down to the grasp."""


def same_prefix(lite: mujoco.MjModel, full: mujoco.MjModel) -> bool:
    """Whether ``lite`` is ``full`` without some last bodies (the props): the same actuators, and every
    body, joint and geom of ``lite`` at the same index in ``full`` (so states carry over index by index)."""
    if lite.nu != full.nu or lite.na != full.na:
        return False
    if not (lite.nbody < full.nbody and lite.njnt <= full.njnt and lite.ngeom <= full.ngeom):
        return False
    pairs = (
        (lite.body_parentid, full.body_parentid),
        (lite.jnt_qposadr, full.jnt_qposadr),
        (lite.jnt_dofadr, full.jnt_dofadr),
        (lite.jnt_bodyid, full.jnt_bodyid),
        (lite.geom_bodyid, full.geom_bodyid),
        (lite.geom_type, full.geom_type),
    )
    return all(np.array_equal(a, b[: len(a)]) for a, b in pairs)


class PhysicsCore:
    """Stepping, contacts, stability checks and states (see the module docstring)."""

    model: mujoco.MjModel
    data: mujoco.MjData
    config: Any
    timers: dict[str, float]
    steps: int
    _props: Any
    _cat: NDArray[np.int64]
    _full: tuple[mujoco.MjModel, mujoco.MjData]
    _lite: tuple[mujoco.MjModel, mujoco.MjData] | None
    _every_step: Any
    _recorder: Any
    _state_spec: Any

    def _step(self, n: int) -> None:
        """Advance the physics ``n`` steps (props on hold come back first if the tool came near them;
        near the props every step's contacts are watched; the recorder is called after)."""
        props = self._props
        if props.held and props.near_held():
            props.release()
        t0 = time.perf_counter()
        if self._every_step is not None and props.near():
            watch, m, d = self._every_step, self.model, self.data
            for _ in range(n):  # near the props: look at every step's contacts (a knock is brief)
                mujoco.mj_step(m, d)
                watch()
        else:
            mujoco.mj_step(self.model, self.data, nstep=n)
        self.timers["physics"] += time.perf_counter() - t0
        self.steps += n
        if self._recorder is not None:
            self._recorder(self)

    def _pair_table(self, first: NDArray[np.bool_], second: NDArray[np.bool_]) -> NDArray[np.bool_]:
        """(ngeom, ngeom) table: True for geom pairs with one geom's category in ``first`` and the
        other's in ``second`` (either way round), to test a step's contacts in one lookup."""
        a, b = first[self._cat], second[self._cat]
        return (a[:, None] & b[None, :]) | (b[:, None] & a[None, :])

    def _contacts(self) -> NDArray[np.int64]:
        """(ncon, 2) geom categories of the current contacts, each row sorted."""
        n = self.data.ncon
        if n == 0:
            return np.zeros((0, 2), dtype=np.int64)
        pairs = np.sort(self._cat[self.data.contact.geom[:n]], axis=1)
        return pairs

    def _check_stable(self) -> None:
        d, e = self.data, self.config.episode
        # Fast path (this runs every check_every steps): NaN fails every comparison, inf the finite sum.
        qvel = d.qvel
        if not (qvel.max() <= e.max_speed and -qvel.min() <= e.max_speed and math.isfinite(d.qpos.sum())):
            if not (np.all(np.isfinite(d.qpos)) and np.all(np.isfinite(qvel))):
                raise Unstable("NaN in the state")
            raise Unstable(f"speed {float(np.max(np.abs(qvel))):.1f}")
        n = d.ncon
        if n:
            contact = d.contact
            dist = contact.dist[:n]
            if dist.min() < -e.max_penetration:
                # Things falling off the table hit the ground fast; only other contacts count as deep.
                cats = self._cat[contact.geom[:n]]
                deep = (dist < -e.max_penetration) & np.all(cats != GROUND, axis=1)
                if np.any(deep):
                    raise Unstable(f"penetration {-float(np.min(dist[deep])):.3f} m")

    # --- the world without props (props on hold) ------------------------------------------------------
    def use_world_without_props(self) -> bool:
        """Step the world built without the props from now on (the props put themselves on hold); False
        when there is none, or a recorder needs the full model (the props then stay, contact-free)."""
        if self._lite is None or self._recorder is not None:
            return False
        self._switch_model(lite=True)
        return True

    def use_full_world(self) -> None:
        """Step the whole world again (no-op if it is the one stepped)."""
        if self.data is not self._full[1]:
            self._switch_model(lite=False)

    def _switch_model(self, lite: bool) -> None:
        """Step the world without the props (``lite``) or with them from now on, carrying the state of
        everything else over (time, positions, velocities, actuators, controls, solver warm start)."""
        assert self._lite is not None
        (fm, fd), (lm, ld) = self._full, self._lite
        src, dst = (fd, ld) if lite else (ld, fd)
        nq, nv, na, nu = lm.nq, lm.nv, lm.na, lm.nu
        dst.time = src.time
        dst.qpos[:nq] = src.qpos[:nq]
        dst.qvel[:nv] = src.qvel[:nv]
        dst.act[:na] = src.act[:na]
        dst.ctrl[:nu] = src.ctrl[:nu]
        dst.qacc_warmstart[:nv] = src.qacc_warmstart[:nv]
        self.model, self.data = (lm, ld) if lite else (fm, fd)
        mujoco.mj_forward(self.model, self.data)

    def _back_to_full_model(self) -> None:
        """After a trial: the full world again (its state is restored from the scene next)."""
        self.model, self.data = self._full
        self._props.held = {}

    # --- states ---------------------------------------------------------------------------------------
    def save_state(self) -> NDArray[np.float64]:
        """The full integration state (a copy), for :meth:`restore_state`."""
        state = np.empty(mujoco.mj_stateSize(self.model, self._state_spec))
        mujoco.mj_getState(self.model, self.data, state, self._state_spec)
        return state

    def restore_state(self, state: NDArray[np.float64]) -> None:
        """Put the world back in a state from :meth:`save_state`."""
        mujoco.mj_setState(self.model, self.data, state, self._state_spec)
        mujoco.mj_forward(self.model, self.data)
