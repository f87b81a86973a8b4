"""Planning for an arm beside the table: every planner plans only what the arm can carry out (issue 25).

With an arm carrying the hand (``SimConfig.robot`` other than the floating gripper: the simulator's in
``tognet evaluate``, or ``tognet plan --robot``), every planner passes its grasps through one filter,
:class:`ArmReach`, as a robot must:

1. **Before any grasp is scored**, the antipodal candidates whose approach, grasp or lift puts the arm's
   wrist beyond its reach are dropped (:class:`Envelope`: the arm's longest stretch from its shoulder,
   vectorised, microseconds per candidate; it drops no grasp the arm reaches). A scene with none left is
   :class:`OutOfReach` at once.
2. **After the planner's choice**, the simulator's own check of a trial (:func:`tognet.sim.arm.plan_reach`:
   inverse kinematics for the approach, then a dry run of the arm's resolved-rate moves through the grasp,
   lift, transport, start pose and motion) checks its grasp and action. Where the arm cannot make it, the
   planner's next grasp is taken (:func:`ranked_grasps`: CEM's next best score, the next NMS mode, the
   action search's next grasp) with its own action; grasps near one whose own steps were out of reach are
   passed over unchecked, and after ``ReachConfig.tries`` grasps found out of reach the plan is
   :class:`OutOfReach`, saying where they fail. The plan says which grasp it took and why
   (``Plan.info["reach"]``).

A check costs about 10 ms where the arm reaches the trial and up to a few tenths of a second where it does
not (every IK seed, the unconstrained solve that tells unreachable from joint_limit, the wrist turned the
long way round): checking every candidate before scoring would cost seconds per plan, so only the grasps
the planner would take are checked, best first. Without an arm none of this runs, and the floating
gripper's plans are unchanged.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from tognet.errors import TognetError
from tognet.grasping.antipodal import GraspCandidates
from tognet.grasping.nms import angle_difference
from tognet.planning.config import ReachConfig
from tognet.planning.plan import PlanningError
from tognet.policies.view import GraspPick, SceneView


class OutOfReach(PlanningError):
    """No grasp the planner would take is within the arm's reach; the message says where they fail, and
    ``dropped`` (:class:`Dropped`) and ``passed`` (the grasps checked, :class:`Passed`) say it in numbers."""

    def __init__(self, message: str, dropped: Dropped | None = None, passed: tuple[Passed, ...] = ()) -> None:
        super().__init__(message)
        self.dropped = dropped
        self.passed = passed


class BasePoseError(TognetError):
    """A base-pose file (``tognet plan --base-pose``) is unusable; the message names it and the problem."""


#: Room (m) the envelope leaves beyond the arm's longest stretch found by search (see :class:`Envelope`).
ENVELOPE_MARGIN = 0.01
#: Grasps whose own steps were checked, kept per arm (a grasp's reach does not depend on the scene).
CACHE_SIZE = 4096


# --- the envelope: where the wrist can be at all -----------------------------------------------------------
def _kinematics(arm: Any) -> Any:
    """Forward kinematics of the arm's model (mink's, the robot extra's: planning imports no MuJoCo)."""
    import mink

    return mink.Configuration(arm.model)


def _longest_stretch(arm: Any, first: int, last: int, seed: int = 0) -> float:
    """The longest distance between the anchors of joints ``first`` and ``last`` (indices into the arm's
    joints) over the joints' ranges: the best of 3,000 random configurations, then a coordinate search
    from the five best (a lower bound of the true longest, closer than a millimetre)."""
    fk = _kinematics(arm)
    ids = [arm.model.joint(n).id for n in arm.joint_names]
    lo, hi = arm.joint_limits.T
    home = arm.home

    def stretch(q: NDArray[np.float64]) -> float:
        full = home.copy()
        full[arm.qpos_adr] = q
        fk.update(full)
        return float(np.linalg.norm(fk.data.xanchor[ids[last]] - fk.data.xanchor[ids[first]]))

    rng = np.random.default_rng(seed)
    samples = rng.uniform(lo, hi, size=(3000, len(lo)))
    lengths = np.array([stretch(q) for q in samples])
    best = 0.0
    for start in np.argsort(-lengths)[:5]:
        q, value, step = samples[start].copy(), float(lengths[start]), 0.2
        while step > 1e-4:
            moved = False
            for j in range(len(q)):
                for sign in (1.0, -1.0):
                    trial = q.copy()
                    trial[j] = np.clip(trial[j] + sign * step, lo[j], hi[j])
                    length = stretch(trial)
                    if length > value:
                        q, value, moved = trial, length, True
            if not moved:
                step /= 2
        best = max(best, value)
    return best


_STRETCH: dict[str, float] = {}


@dataclass(frozen=True)
class Envelope:
    """Where an arm's hand can be at all, pointing down: the wrist (the last joint's anchor, fixed in the
    hand's frame) within ``length`` of the shoulder (the second joint's anchor), which the base's vertical
    first joint swings round a ring (``ring_radius`` from its axis, at ``ring_height``).

    ``length`` is the shorter of the sum of the distances between consecutive joint anchors from shoulder
    to wrist (each is fixed by the links: a bound no configuration exceeds) and the longest stretch the
    joints' ranges allow (found by search, :func:`_longest_stretch`) plus :data:`ENVELOPE_MARGIN`. A pose
    beyond it is out of reach for any joint angles; one within it may still be (IK tells)."""

    centre: tuple[float, float]  # the first joint's vertical axis (x, y)
    ring_radius: float
    ring_height: float
    length: float
    wrist: tuple[float, float, float]  # the last joint's anchor in the TCP frame (x jaw, z out of the hand)

    @classmethod
    def of_arm(cls, arm: Any) -> Envelope:
        """The envelope of an arm (``tognet.robot.ArmModel``) where its base stands, carrying its hand
        (the stretch between the joints depends on neither: searched once per arm)."""
        fk = _kinematics(arm)
        fk.update(arm.home)
        data = fk.data
        ids = [arm.model.joint(n).id for n in arm.joint_names]
        anchors = np.array([data.xanchor[i] for i in ids], dtype=np.float64)
        tcp = np.array(data.site_xpos[arm.tcp_site], dtype=np.float64)
        rot = np.array(data.site_xmat[arm.tcp_site], dtype=np.float64).reshape(3, 3)
        wrist = rot.T @ (anchors[-1] - tcp)
        links = float(np.linalg.norm(np.diff(anchors[1:], axis=0), axis=1).sum())
        if arm.spec.name not in _STRETCH:
            _STRETCH[arm.spec.name] = _longest_stretch(arm, 1, len(ids) - 1)
        length = min(links, _STRETCH[arm.spec.name] + ENVELOPE_MARGIN)
        axis = np.array(data.xaxis[ids[0]], dtype=np.float64)
        if abs(abs(axis[2]) - 1.0) < 1e-6:  # a vertical first joint: the shoulder swings round a ring
            ring = float(np.hypot(*(anchors[1, :2] - anchors[0, :2])))
            return cls((float(anchors[0, 0]), float(anchors[0, 1])), ring, float(anchors[1, 2]), length,
                       tuple(map(float, wrist)))
        # Otherwise a sphere round the first joint's anchor (the shoulder's distance from it added).
        length += float(np.linalg.norm(anchors[1] - anchors[0]))
        return cls((float(anchors[0, 0]), float(anchors[0, 1])), 0.0, float(anchors[0, 2]), length,
                   tuple(map(float, wrist)))

    def excess(self, poses: ArrayLike) -> NDArray[np.float64]:
        """(N,) how far (m) each top-down pose (x, y, z, phi) puts the wrist beyond the envelope (<= 0:
        within)."""
        p = np.asarray(poses, dtype=np.float64).reshape(-1, 4)
        c, s = np.cos(p[:, 3]), np.sin(p[:, 3])
        dx, dy, dz = self.wrist
        # The TCP frame of a top-down pose (tognet.robot.ik.grasp_frame): x (c, s, 0), y (s, -c, 0),
        # z (0, 0, -1).
        wx = p[:, 0] + dx * c + dy * s
        wy = p[:, 1] + dx * s - dy * c
        wz = p[:, 2] - dz
        r = np.hypot(wx - self.centre[0], wy - self.centre[1])
        return np.hypot(r - self.ring_radius, wz - self.ring_height) - self.length


# --- what the planner would take, and what the arm makes of it ---------------------------------------------
def ranked_grasps(policy: Any, view: SceneView, rng: np.random.Generator, n: int) -> GraspPick:
    """The grasps ``policy`` would take on ``view``, best first: its ``ranked(view, rng)`` where it has
    one (every grasp CEM scored by score, the NMS modes in a random order, the action search's grasps by
    rating), else ``n`` of its picks."""
    ranked = getattr(policy, "ranked", None)
    return ranked(view, rng) if ranked is not None else policy(view, n, rng)


@dataclass(frozen=True)
class Option:
    """A grasp a planner would take, and how to get its action: ``action()`` returns the action (4,) and
    whatever the planner keeps with it (called only once the grasp's own steps are within reach)."""

    grasp: NDArray[np.float64]
    action: Callable[[], tuple[NDArray[np.float64], Any]]


@dataclass(frozen=True)
class Dropped:
    """The candidates set aside before scoring: how many there were, and how many were beyond the
    envelope, by the first of the grasp's steps that was."""

    candidates: int
    by_step: dict[str, int] = field(default_factory=dict)

    @property
    def count(self) -> int:
        return sum(self.by_step.values())


@dataclass(frozen=True)
class Passed:
    """A grasp checked and found out of reach: the step (``tognet.sim.arm.Step`` name) and the reason
    ("unreachable" or "joint_limit")."""

    grasp: NDArray[np.float64]
    what: str
    reason: str


@dataclass(frozen=True)
class ReachChoice:
    """A grasp and action the arm carries out: the planner's ``extra`` kept with them, the joint path
    through the trial's steps (``reach``, :class:`tognet.sim.arm.Reach`), its rank among the planner's
    options (0: the planner's own choice), the grasps checked before it and found out of reach, the options
    passed over unchecked, the candidates dropped before scoring, and whether the task's steps were
    checked (False: the grasp's alone, no reference point given)."""

    arm: str
    grasp: NDArray[np.float64]
    action: NDArray[np.float64]
    extra: Any
    reach: Any
    rank: int
    passed: tuple[Passed, ...]
    skipped: int
    dropped: Dropped
    checked: int
    seconds: float
    with_task: bool

    def waypoints(self) -> list[dict[str, Any]]:
        """Per step of the trial (approach, grasp, lift, then with the task transport, start pose and
        motion): its name, the hand's pose (x, y, z, phi), the joint angles (base to wrist) and the earliest
        time (s) it can be there, from the first step, at the joints' speed limits."""
        path = self.reach.path
        times = np.concatenate([[0.0], np.cumsum(path.min_times)])
        return [{"step": what, "pose": [*map(float, pos), float(yaw)], "q": [float(v) for v in q],
                 "time": float(t)}
                for (what, pos, yaw), q, t in zip(self.reach.steps, path.q, times, strict=True)]

    def info(self) -> dict[str, Any]:
        """What the plan says about its reach (``Plan.info["reach"]``)."""
        return {"arm": self.arm, "candidates": self.dropped.candidates, "dropped": self.dropped.count,
                "checked": self.checked, "rank": self.rank, "skipped": self.skipped,
                "passed_over": [{"grasp": [float(v) for v in p.grasp], "step": p.what, "reason": p.reason}
                                for p in self.passed],
                "with_task": self.with_task, "wrist_turn": float(self.reach.turn),
                "duration": float(self.reach.path.min_duration)}

    def summary(self) -> str | None:
        """One line on what was passed over, or None when the planner's own choice was taken."""
        if self.rank == 0:
            return None
        first = self.passed[0] if self.passed else None
        why = (f"{first.what} is {_REASONS.get(first.reason, first.reason)}" if first is not None
               else "it is out of reach")
        return (f"the planner's best grasp is out of the {self.arm}'s reach ({why}): took its next within "
                f"reach (#{self.rank + 1} of its ranking, {len(self.passed)} checked before it)")


_REASONS = {"unreachable": "out of reach", "joint_limit": "past a joint's limit"}


class ArmReach:
    """What an arm beside the table reaches (see the module docstring): built from a ``SimConfig`` whose
    robot is an arm (its base, its hand: the simulator's) and the task whose steps are checked (None:
    the grasp's alone). RobotExtraMissing without the robot extra."""

    def __init__(self, sim_config: Any, task: Any = None, config: ReachConfig | None = None) -> None:
        from tognet.robot.arms import arm_spec
        from tognet.sim.arm import arm_solver

        if sim_config.robot.name == "floating":
            raise ValueError("the floating gripper has no arm to plan for")
        self.sim_config = sim_config
        self.task = task
        self.config = config or ReachConfig()
        self.solver = arm_solver(sim_config)  # the simulator's own (shared: its checks leave it as found)
        self.arm, self.ik = self.solver.arm, self.solver.ik
        r, spec = sim_config.robot, arm_spec(sim_config.robot.name)
        self.name: str = r.name
        self.base_position = tuple(float(v) for v in (r.base_position or spec.base_pos))
        self.base_yaw = float(spec.base_yaw if r.base_yaw is None else r.base_yaw)
        self.envelope = Envelope.of_arm(self.arm)
        self._own: dict[bytes, Any] = {}

    @property
    def joint_names(self) -> list[str]:
        """The arm's joints, base to wrist (the order of every waypoint's angles)."""
        return list(self.arm.joint_names)

    def describe_base(self) -> str:
        x, y, z = self.base_position
        return f"base at ({x:.2f}, {y:.2f}, {z:.2f}) m, yaw {self.base_yaw:.2f} rad"

    # --- before scoring --------------------------------------------------------------------------------
    def grasp_step_poses(self, grasps: ArrayLike) -> tuple[list[str], NDArray[np.float64]]:
        """The names of the grasp's steps and their poses (N, steps, 4) for each grasp
        (:func:`tognet.sim.arm.trial_steps` without a task: approach, grasp, lift)."""
        from tognet.sim.arm import trial_steps

        g = np.asarray(grasps, dtype=np.float64).reshape(-1, 4)
        names: list[str] = []
        poses = []
        for x, y, z, phi in g:
            steps = trial_steps(self.sim_config, None, (x, y, z), float(phi), None, None)
            names = [what for what, _, _ in steps]
            poses.append([[*pos, yaw] for _, pos, yaw in steps])
        if not poses:
            return names, np.zeros((0, 3, 4))
        return names, np.asarray(poses, dtype=np.float64)

    def beyond(self, grasps: ArrayLike) -> tuple[NDArray[np.bool_], list[str | None]]:
        """Which grasps put the wrist beyond the envelope at one of their own steps, and the first such
        step of each (None: within)."""
        names, poses = self.grasp_step_poses(grasps)
        n = len(poses)
        if n == 0:
            return np.zeros(0, dtype=bool), []
        out = self.envelope.excess(poses.reshape(-1, 4)).reshape(n, -1) > 0
        first = [names[int(np.argmax(row))] if row.any() else None for row in out]
        return out.any(axis=1), first

    def keep(self, grasps: ArrayLike) -> tuple[NDArray[np.bool_], Dropped]:
        """Which candidate grasps lie within the envelope, and what was dropped; OutOfReach when none."""
        far, first = self.beyond(grasps)
        counts: dict[str, int] = {}
        for what in first:
            if what is not None:
                counts[what] = counts.get(what, 0) + 1
        dropped = Dropped(len(far), counts)
        if len(far) and far.all():
            raise OutOfReach(self._message(dropped, [], False), dropped)
        return ~far, dropped

    def filter(self, candidates: GraspCandidates) -> tuple[GraspCandidates, Dropped]:
        """The candidates within the envelope (the same object when none is dropped) and what was dropped;
        OutOfReach when none is left."""
        keep, dropped = self.keep(candidates.grasps)
        if keep.all():
            return candidates, dropped
        return candidates.subset(np.flatnonzero(keep)), dropped

    # --- after the choice ------------------------------------------------------------------------------
    def own_steps(self, grasp: ArrayLike) -> Any:
        """The grasp's own steps (approach, grasp, lift) as the simulator checks them
        (:func:`tognet.sim.arm.plan_reach` without a task): a :class:`tognet.sim.arm.Reach` (cached per
        grasp)."""
        from tognet.sim.arm import plan_reach

        g = np.asarray(grasp, dtype=np.float64).reshape(4)
        key = g.tobytes()
        if key not in self._own:
            if len(self._own) >= CACHE_SIZE:
                self._own.clear()
            self._own[key] = plan_reach(self.sim_config, None, self.solver, g[:3], float(g[3]), None, None)
        return self._own[key]

    def trial(self, grasp: ArrayLike, action: ArrayLike, reference: ArrayLike | None) -> Any:
        """The whole trial of ``grasp`` and ``action`` as the simulator checks it before running it
        (:func:`tognet.sim.arm.plan_reach`, without the execution noise); the grasp's own steps alone
        without a task or a reference point. A step beyond the envelope (a start pose far from the arm) is
        out of reach without inverse kinematics (``path`` None)."""
        from tognet.robot.arms import ArmStuck
        from tognet.sim.arm import Reach, plan_reach, trial_steps

        g = np.asarray(grasp, dtype=np.float64).reshape(4)
        if self.task is None or reference is None:
            return self.own_steps(g)
        ref, act = np.asarray(reference, dtype=np.float64), np.asarray(action, dtype=np.float64)
        steps = trial_steps(self.sim_config, self.task, g[:3], float(g[3]), ref, act)
        far = self.envelope.excess([[*pos, yaw] for _, pos, yaw in steps]) > 0
        if far.any():
            return Reach(steps, None, ArmStuck("unreachable", steps[int(np.argmax(far))][0]))
        return plan_reach(self.sim_config, self.task, self.solver, g[:3], float(g[3]), ref, act)

    def _near(self, grasp: NDArray[np.float64], others: list[NDArray[np.float64]], spacing: float,
              angle: float) -> bool:
        if not others:
            return False
        o = np.asarray(others)
        close = np.linalg.norm(o[:, :3] - grasp[:3], axis=1) <= spacing
        return bool(np.any(close & (angle_difference(o[:, 3], grasp[3]) <= angle)))

    def choose(self, options: Iterable[Option], reference: ArrayLike | None, dropped: Dropped,
               want: int = 1) -> list[ReachChoice]:
        """The first ``want`` options (best first) whose whole trial the arm reaches; OutOfReach when none
        is, or when ``config.tries`` options were found out of reach before the first."""
        cfg = self.config
        t0 = time.perf_counter()
        found: list[ReachChoice] = []
        passed: list[Passed] = []
        failed_own: list[NDArray[np.float64]] = []
        checked: list[NDArray[np.float64]] = []
        skipped = 0
        with_task = self.task is not None and reference is not None
        for rank, option in enumerate(options):
            if len(found) >= want or len(passed) >= cfg.tries:
                break
            g = np.asarray(option.grasp, dtype=np.float64).reshape(4)
            if self.beyond(g)[0][0] or self._near(g, failed_own, cfg.spacing, cfg.angle_spacing) \
                    or self._near(g, checked, 1e-9, 1e-9):
                skipped += 1
                continue
            checked.append(g)
            own = self.own_steps(g)
            if own.stuck is not None:
                passed.append(Passed(g, own.stuck.what, own.stuck.reason))
                failed_own.append(g)
                continue
            action, extra = option.action()
            reach = self.trial(g, action, reference)
            if reach.stuck is not None:
                passed.append(Passed(g, reach.stuck.what, reach.stuck.reason))
                continue
            found.append(ReachChoice(self.name, g.copy(), np.asarray(action, dtype=np.float64).copy(), extra,
                                     reach, rank, tuple(passed), skipped, dropped, len(checked),
                                     time.perf_counter() - t0, with_task))
        if not found:
            raise OutOfReach(self._message(dropped, passed, len(passed) >= cfg.tries), dropped, tuple(passed))
        return found

    def out_of_reach(self, dropped: Dropped, passed: list[Passed]) -> OutOfReach:
        """The error of a search (the Oracle's) that found every grasp it looked at out of reach."""
        return OutOfReach(self._message(dropped, passed, False), dropped, tuple(passed))

    def search_info(self, dropped: Dropped, passed: list[Passed], reached: int) -> dict[str, Any]:
        """What a search's plan (the Oracle's) says about its reach: the candidates dropped before it, the
        grasps it passed over and how many it could try."""
        return {"arm": self.name, "candidates": dropped.candidates, "dropped": dropped.count,
                "checked": len(passed) + reached, "reached": reached,
                "passed_over": [{"grasp": [float(v) for v in p.grasp], "step": p.what, "reason": p.reason}
                                for p in passed]}

    def _message(self, dropped: Dropped, passed: list[Passed], exhausted: bool) -> str:
        parts = []
        if dropped.count:
            steps = sorted(dropped.by_step.items(), key=lambda kv: -kv[1])
            (what, n), rest = steps[0], steps[1:]
            text = f"{what} is out of reach for {n} of {dropped.candidates} candidates"
            parts.append(text + "".join(f", {w} for {k}" for w, k in rest))
        if passed:
            counts: dict[tuple[str, str], int] = {}
            for p in passed:
                counts[(p.what, p.reason)] = counts.get((p.what, p.reason), 0) + 1
            items = [f"{what} is {_REASONS.get(reason, reason)} for {n}"
                     for (what, reason), n in sorted(counts.items(), key=lambda kv: -kv[1])]
            head = (f"of the planner's {len(passed)} best grasps {'left ' if dropped.count else ''}"
                    "checked against the arm's kinematics, ")
            parts.append(head + ", ".join(items)
                         + (f" (ReachConfig.tries = {self.config.tries})" if exhausted else ""))
        return f"no grasp within the {self.name}'s reach ({self.describe_base()}): " + "; ".join(parts)


class FramedReach:
    """An :class:`ArmReach` for grasps given in another frame than its base's (a user's image: grasps in
    the plan's table frame, the arm's base and the reference point in the camera pose's world frame).
    ``frame_from_plan``: the 4 x 4 rigid transform from the grasps' frame to the base's (identity: the
    same frame). Grasps go in and come out in the plan's frame; the trajectories are in the base's."""

    def __init__(self, reach: ArmReach, frame_from_plan: NDArray[np.float64]) -> None:
        self.reach = reach
        self.frame_from_plan = np.asarray(frame_from_plan, dtype=np.float64)
        self.config, self.name = reach.config, reach.name

    def to_frame(self, grasps: ArrayLike) -> NDArray[np.float64]:
        """Grasps (N, 4) of the plan's frame in the base's (position moved, the jaw axis' yaw turned)."""
        g = np.asarray(grasps, dtype=np.float64).reshape(-1, 4)
        t = self.frame_from_plan
        p = g[:, :3] @ t[:3, :3].T + t[:3, 3]
        jaw = np.stack([np.cos(g[:, 3]), np.sin(g[:, 3]), np.zeros(len(g))], axis=1) @ t[:3, :3].T
        return np.column_stack([p, np.mod(np.arctan2(jaw[:, 1], jaw[:, 0]), 2 * np.pi)])

    def filter(self, candidates: GraspCandidates) -> tuple[GraspCandidates, Dropped]:
        """:meth:`ArmReach.filter` of candidates in the plan's frame."""
        keep, dropped = self.reach.keep(self.to_frame(candidates.grasps))
        if keep.all():
            return candidates, dropped
        return candidates.subset(np.flatnonzero(keep)), dropped

    def choose(self, options: Iterable[Option], reference: ArrayLike | None, dropped: Dropped,
               want: int = 1) -> list[ReachChoice]:
        """:meth:`ArmReach.choose` of options in the plan's frame (``reference`` in the base's); the
        choices' grasps in the plan's frame."""
        def moved(o: Option) -> Option:
            def action() -> tuple[NDArray[np.float64], Any]:
                a, extra = o.action()
                return a, (o.grasp, extra)

            return Option(self.to_frame(o.grasp)[0], action)

        found = self.reach.choose((moved(o) for o in options), reference, dropped, want)
        return [replace(c, grasp=np.asarray(c.extra[0], dtype=np.float64).copy(), extra=c.extra[1])
                for c in found]


def reach_of(sim_config: Any, task: Any, config: ReachConfig | None = None) -> ArmReach | None:
    """The filter for ``sim_config``'s arm, None for the floating gripper or with ``config.enabled`` off."""
    config = config or ReachConfig()
    if sim_config.robot.name == "floating" or not config.enabled:
        return None
    return ArmReach(sim_config, task, config)


# --- a robot's base for tognet plan ----------------------------------------------------------------------
def load_base_pose(path: str | Path) -> tuple[tuple[float, float, float], float]:
    """The arm's base from a JSON file ``{"position": [x, y, z], "yaw": rad}`` (m; the frame of the plan's
    reference point: the camera pose's world frame, else the plan's table frame; z = 0 the table top):
    (position, yaw). BasePoseError naming the file and the problem otherwise; FileNotFoundError when it is
    not there."""
    import json

    path = Path(path)
    if not path.is_file():
        folder = " (it is a folder)" if path.is_dir() else ""
        raise FileNotFoundError(f"base pose file not found: {path}{folder}")
    try:
        data = json.loads(path.read_text())
    except UnicodeDecodeError as exc:
        raise BasePoseError(f"{path}: not a JSON text file ({exc.reason})") from None
    except json.JSONDecodeError as exc:
        raise BasePoseError(f"{path}: not valid JSON ({exc})") from None
    form = '{"position": [x, y, z], "yaw": radians}'
    if not isinstance(data, dict):
        raise BasePoseError(f"{path}: expected a JSON object {form}, got {type(data).__name__}")
    unknown = sorted(set(data) - {"position", "yaw", "comment", "frame"})
    missing = [k for k in ("position", "yaw") if k not in data]
    if unknown or missing:
        what = "; ".join(x for x in (f"missing {', '.join(missing)}" if missing else "",
                                     f"unknown {', '.join(unknown)}" if unknown else "") if x)
        raise BasePoseError(f"{path}: {what} (expected {form})")
    position, yaw = data["position"], data["yaw"]
    numbers = isinstance(position, list) and len(position) == 3 and all(
        isinstance(v, int | float) and not isinstance(v, bool) for v in position)
    if not numbers:
        raise BasePoseError(f"{path}: position must be 3 numbers [x, y, z] (m), got {position!r}")
    if not isinstance(yaw, int | float) or isinstance(yaw, bool):
        raise BasePoseError(f"{path}: yaw must be a number (rad), got {yaw!r}")
    values = [float(v) for v in position] + [float(yaw)]
    if not all(math.isfinite(v) for v in values):
        raise BasePoseError(f"{path}: position and yaw must be finite numbers, got {position!r}, {yaw!r}")
    if abs(values[3]) > 2 * math.pi + 1e-6:
        raise BasePoseError(f"{path}: yaw {values[3]:g} is more than a turn: radians expected (degrees? "
                            f"{values[3]:g} degrees is {math.radians(values[3]):.4f} rad)")
    if max(abs(v) for v in values[:3]) > 10:
        raise BasePoseError(f"{path}: the base is {max(abs(v) for v in values[:3]):g} m from the frame's "
                            "origin: metres expected (millimetres?)")
    return (values[0], values[1], values[2]), values[3]
