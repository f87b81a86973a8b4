"""What a task hands the simulator: its props (the objects it acts on) and how to watch them.

The simulator core (:mod:`tognet.sim`) knows no task. It builds the world from the props' MJCF
(:meth:`TaskProps.mjcf`), places them from the task's random layout (:meth:`TaskProps.place`), asks
where they are (:meth:`TaskProps.positions`: a prop that moved was touched) and whether the tool could
touch them soon (:meth:`TaskProps.near`: then every physics step's contacts are read), lets them watch
each checked step while the primitive runs (:meth:`TaskProps.primitive_watch`), and reads the outcome
values the task's success rule judges (:meth:`TaskProps.outcome`).

Props may also take themselves out of the physics while the tool is far from them (:meth:`TaskProps.hold`,
a pure speed-up: they come back exactly as they stood before anything can touch them). And they carry
their task's privileged, hand-computed knowledge: the oracle's actions for a grasp
(:meth:`TaskProps.oracle_actions`) and the scripted checks on a hand-made object
(:attr:`TaskProps.check_object`, :attr:`TaskProps.check_grasps`, :meth:`TaskProps.check_action`).

No MuJoCo import here: props read and write the model and data arrays the simulator hands them (its
``model`` and ``data`` attributes, which may change between calls: read them each time).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np
from numpy.typing import NDArray

from tognet.geometry import Grasp
from tognet.tasks.base import Task


class PropsHost(Protocol):
    """What props may use of the simulator that holds them (:class:`tognet.sim.Simulator`)."""

    model: Any  # the MuJoCo model being stepped (the full world, or the world without props on hold)
    data: Any  # its data
    config: Any  # the SimConfig (world, gripper and physics sections)

    @property
    def object_reach(self) -> float: ...  # radius (m) around the object's body origin holding all of it

    @property
    def object_body(self) -> int: ...  # the object's body id

    @property
    def body_vertices(self) -> NDArray[np.float64]: ...  # collision vertices in the body frame

    @property
    def vertices(self) -> NDArray[np.float64]: ...  # collision vertices in the object's own frame

    @property
    def vertex_pieces(self) -> tuple[int, ...]: ...  # vertices per convex collision piece, in order

    @property
    def scene(self) -> Mapping[str, Any] | None: ...  # the settled scene (seed, layout, reference)

    @property
    def task(self) -> Task | None: ...

    def hand_xy(self) -> tuple[float, float]: ...  # where the hand (the grasp centre) is now, world x, y

    def object_pose(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]: ...

    def use_world_without_props(self) -> bool: ...  # step the world built without props; False: none

    def use_full_world(self) -> None: ...  # back to the whole world (no-op if already there)


@dataclass(frozen=True)
class PropsMJCF:
    """The props' part of the world's MJCF."""

    bodies: list[str] = field(default_factory=list)  # worldbody lines (after the object and gripper)
    contact: list[str] = field(default_factory=list)  # <contact> children (e.g. pair excludes)
    touch_bodies: list[str] = field(default_factory=list)  # prop bodies whose contacts with the tool or
    # the hand count as touching them (contact sensors, read every step near the props)
    target_geoms: list[str] = field(default_factory=list)  # the geoms the primitive must hit (touched)
    other_geoms: list[str] = field(default_factory=list)  # the props' other geoms


#: Called after a checked step of the primitive with the (ncon, 2) geom ids of its contacts (None when
#: there are none).
StepWatch = Callable[[NDArray[np.int32] | None], None]


class TaskProps:
    """A task's props in the simulator. This base class is the empty set (grasping only): no props,
    nothing to watch; a task subclasses it (see :mod:`tognet.tasks.sweeping_props`)."""

    #: Whether the props can be put on hold (:meth:`hold`); the simulator then builds the world once
    #: more without the props, to step while they are on hold.
    can_hold: bool = False
    #: Hand-made object (an id of :func:`tognet.objects.handmade.make_test_tools`) the scripted checks use.
    check_object: str = ""
    #: Scripted-check grasps on it, by name: (grasp point, jaw axis, ...) in the object's frame.
    check_grasps: Mapping[str, tuple[Any, ...]] = {}
    #: What each grasp of ``check_grasps`` is, in words (what the demo prints beside its result).
    check_texts: Mapping[str, str] = {}
    #: The grasp of ``check_grasps`` known to succeed (what a demo shows first).
    demo_grasp: str = ""
    #: Outcome values (:meth:`outcome`) the scripted checks report per trial.
    outcome_keys: tuple[str, ...] = ()

    def __init__(self, task: Task | None = None) -> None:
        self.task = task
        self.config: Any = task.config if task is not None else None
        self.host: PropsHost | None = None
        self.layout: dict[str, Any] = {}
        #: Props on hold (out of the physics), by index: their state when put on hold.
        self.held: dict[int, tuple[NDArray[np.float64], ...]] = {}

    # --- world ----------------------------------------------------------------------------------------
    def mjcf(self, sim_config: Any, group: int) -> PropsMJCF:
        """The props' MJCF for the world built from ``sim_config``; their geoms in geom ``group``."""
        return PropsMJCF()

    def bind(self, host: PropsHost) -> None:
        """Look up the props' ids in the host's (full) model, once, after the world is built."""
        self.host = host

    # --- scene ----------------------------------------------------------------------------------------
    def sample_layout(self, rng: np.random.Generator) -> dict[str, Any]:
        """The task's random layout of the props for one scene (plain numbers)."""
        return self.task.sample_layout(rng) if self.task is not None else {}

    def reference(self, layout: dict[str, Any]) -> NDArray[np.float64]:
        """The task's reference point (world) for ``layout``; zeros without a task."""
        return self.task.reference(layout) if self.task is not None else np.zeros(3)

    def place(self, layout: dict[str, Any]) -> None:
        """Put the props where ``layout`` says, at rest (the simulator's reset, before settling)."""
        self.layout = layout

    def activate(self) -> None:
        """At the start and end of a trial: the props of the scene in play (model fields a trial may have
        changed, e.g. parked props, are set again)."""

    # --- while a trial runs ---------------------------------------------------------------------------
    def positions(self) -> NDArray[np.float64]:
        """(k, 3) positions of the props that count as touched when they move; empty without props."""
        return np.zeros((0, 3))

    def near(self) -> bool:
        """Whether the tool or the hand could touch a prop within the next chunk of steps."""
        return False

    def hold(self) -> None:
        """Before the grasp: take props the tool is far from out of the physics (see :attr:`can_hold`)."""

    def near_held(self) -> bool:
        """Whether the tool or the hand came near a prop on hold (then :meth:`release` before stepping)."""
        return False

    def release(self) -> None:
        """Every prop on hold back in play, as it stood."""

    def primitive_watch(self) -> StepWatch | None:
        """A fresh watcher for one primitive run, or None when there is nothing to watch."""
        return None

    def settled(self) -> Callable[[], bool] | None:
        """After the primitive: a test that ends the settling wait early, or None (wait it out)."""
        return None

    def outcome(self) -> tuple[dict[str, Any], bool]:
        """The task's measured values after settling, and whether props are still moving."""
        return {}, False

    # --- privileged knowledge (oracle, scripted checks) ----------------------------------------------
    def oracle_actions(self, pts: NDArray[np.float64], **options: Any) -> list[NDArray[np.float64]]:
        """Hand-computed candidate actions for a tool whose collision vertices in the gripper frame are
        ``pts`` (:func:`tool_in_gripper`), in the host's settled scene."""
        raise ValueError("no hand-computed actions without a task")

    def check_config(self, task_config: Any) -> Any:
        """The task config the scripted checks run under (default: as given)."""
        return task_config

    def check_action(
        self, grasp: str | tuple[Any, ...], clip: bool = True, yaw: float = 0.0
    ) -> NDArray[np.float64]:
        """The scripted checks' hand-computed action for a grasp of :attr:`check_grasps` (its name or its
        spec) on the hand-made object in the host's settled scene."""
        raise ValueError("no scripted checks without a task")


def tool_in_gripper(sim: PropsHost, grasp: Grasp, in_hand: object = None) -> NDArray[np.float64]:
    """(N, 3) collision vertices of the object in the gripper frame of ``grasp`` (x = jaw axis at yaw
    phi, z up, origin at the grasp centre): from ``in_hand`` (the (3, 4) pose a trial's
    ``info["in_hand"]`` reports after the lift) if given, else the settled pose taken into the hand."""
    if in_hand is not None:
        pose = np.asarray(in_hand, dtype=np.float64)
        return sim.vertices @ pose[:, :3].T + pose[:, 3]
    pos, rot = sim.object_pose()
    world = sim.vertices @ rot.T + pos
    d = world - grasp.position
    r = rot2(-grasp.phi)
    xy = d[:, :2] @ r.T
    return np.column_stack([xy, d[:, 2]])


def rot2(a: float) -> NDArray[np.float64]:
    """2-D rotation matrix by ``a`` (rad)."""
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s], [s, c]])


def in_gripper(point: Any, grasp_point: Any, jaw: Any) -> NDArray[np.float64]:
    """Object-frame point in the gripper frame (x = jaw axis, z up), for a tool lying flat."""
    d = np.asarray(point, dtype=np.float64) - np.asarray(grasp_point, dtype=np.float64)
    jaw = np.asarray(jaw, dtype=np.float64)
    return np.array([jaw @ d, np.cross([0.0, 0.0, 1.0], jaw) @ d, d[2]])
