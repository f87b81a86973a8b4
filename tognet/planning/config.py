"""Settings of the planners (saved with every evaluation)."""

from __future__ import annotations

from dataclasses import dataclass

from tognet.config import Config, doc
from tognet.grasping.antipodal import AntipodalConfig
from tognet.grasping.crops import CropConfig
from tognet.policies.config import PolicyConfig


@dataclass(frozen=True)
class OracleConfig(Config):
    """The Oracle's search (simulator ground truth; an upper bound, never a deployable method)."""

    grasps: int = doc(
        8,
        "NMS modes of the antipodal candidates (ranked by antipodal quality) tried, each held both ways "
        "round (phi and phi + pi): up to twice this many grasps.",
        ge=1,
    )
    seeds: int = doc(
        2,
        "Search trials per (grasp, action) pair, on execution-noise seeds the evaluation never uses; the "
        "first pair that succeeds on all of them is taken at once.",
        ge=1,
    )
    max_trials: int = doc(
        96, "Search trials per plan at most (probes included); then the best pair found so far is taken.",
        ge=1,
    )


@dataclass(frozen=True)
class BoundConfig(Config):
    """Oracle+, the stronger bound (simulator ground truth; never a deployable method): every method's own
    plan tried in the simulator, then the Oracle's motion from those grasps, then a wider Oracle search,
    then small moves of the best action, within one budget (:mod:`tognet.planning.bound`)."""

    grasps: int = doc(16, "NMS modes of the antipodal candidates the wider Oracle search tries, each held "
                      "both ways round.", ge=1)
    seeds: int = doc(
        3,
        "Search trials per (grasp, action) pair, on execution-noise seeds the evaluation never uses (a "
        "pair that fails once is not tried further).",
        ge=1,
    )
    confirm: int = doc(
        5, "More trials for a pair that won all its seeds' trials; a pair that wins these too is taken.", ge=0
    )
    tiebreak: int = doc(
        10,
        "When several of stage 1's plans win all their seeds' and confirmation trials, each is tried on this "
        "many more (every trial counted, not stopping at a failure) and the one that wins most is taken.",
        ge=0,
    )
    max_trials: int = doc(512, "Search trials per plan at most, over every stage (the Oracle's included).",
                          ge=1)
    alternatives: int = doc(
        2, "The learned methods' next grasps (ranked their way, 3 cm apart) tried beside their plan.", ge=0
    )
    step: float = doc(0.01, "Stage 4: how far the best pair's action start is moved along x, y and z (m).",
                      gt=0)
    turn: float = doc(0.1, "Stage 4: how far the best pair's action is turned in yaw (rad).", gt=0)


@dataclass(frozen=True)
class TwinConfig(Config):
    """The image's twin (:mod:`tognet.planning.twin`): a solid built from the depth image alone, set in a
    simulated world with the props where the robot is told they are, in which the action search's best
    (grasp, action) pairs are tried before one is chosen. It reads no ground truth: only the image, its
    camera, the reference point and nominal values for what the image cannot show."""

    pairs: int = doc(8, "The action search's best (grasp, action) pairs tried in the twin.", ge=1)
    seeds: int = doc(3, "Trials per pair in the twin, on execution-noise seeds of their own.", ge=1)
    cell: float = doc(0.02, "Width (m) of the grid cells the image's object is cut into (one convex "
                      "piece each).", gt=0)
    min_height: float = doc(0.004, "Pixels this high (m) above the table or more are the object's.", gt=0)
    max_x: float = doc(0.12, "Pixels with a world x up to this (m) are the object's (the props lie beyond; "
                       "the grasping half is x < 0).")
    density: float = doc(1000.0, "The twin's density (kg/m^3): not in the image, a nominal one.", gt=0)
    friction: float = doc(0.85, "The twin's sliding friction: not in the image, the middle of the "
                          "generators' range.", gt=0)


@dataclass(frozen=True)
class ReachConfig(Config):
    """Planning for an arm (:mod:`tognet.planning.reach`): which of a planner's grasps an arm beside the
    table can carry out. Used only when an arm carries the hand (``SimConfig.robot`` not floating, or
    ``tognet plan --robot``): the floating gripper's plans never see it."""

    enabled: bool = doc(
        True,
        "Plan only what the simulator's arm reaches when it has one (false: plan as for the floating "
        "gripper, and let the trial find out).",
    )
    tries: int = doc(
        6,
        "Grasps checked by inverse kinematics per plan at most (the planner's own choice, then its next "
        "best ones); then the plan is out of reach. A check costs about 10 ms where the arm reaches the "
        "whole trial and up to 0.2 s where it does not.",
        ge=1,
    )
    spacing: float = doc(
        0.02,
        "A grasp within this distance (m) and ``angle_spacing`` of one whose approach, grasp or lift was out "
        "of reach is passed over without a check of its own.",
        ge=0,
    )
    angle_spacing: float = doc(0.3, "See ``spacing`` (rad).", ge=0)


@dataclass(frozen=True)
class PlanConfig(Config):
    """How the planners sample, rank and search grasps (the collection's settings by default, so that the
    models are queried on the inputs they were trained on)."""

    antipodal: AntipodalConfig = doc(
        factory=lambda: AntipodalConfig(axis_direction="both"),
        text="Antipodal candidates (both jaw orientations, as in collection): CEM's start, the "
        "Antipodal+Random baseline's pool and the Oracle's grasps.",
    )
    crop: CropConfig | None = doc(
        None, "The network's crops; None: the models' own (from their checkpoints, which must agree)."
    )
    policy: PolicyConfig = doc(
        factory=PolicyConfig,
        text="CEM (on Q_T or Q_G), NMS and its number of modes (the Antipodal+Random pool); its exploration "
        "fields are unused (a planner's action is the policy's mean: no noise).",
    )
    oracle: OracleConfig = doc(factory=OracleConfig, text="The Oracle's simulator search.")
    bound: BoundConfig = doc(factory=BoundConfig, text="Oracle+'s search (the stronger bound).")
    twin: TwinConfig = doc(factory=TwinConfig, text="TOG-Net+Twin's trials in the image's twin.")
    reach: ReachConfig = doc(
        factory=ReachConfig, text="With an arm carrying the hand: what every planner checks it reaches."
    )
