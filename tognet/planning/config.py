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
