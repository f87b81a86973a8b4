"""Configs of self-supervised collection and of the whole pipeline (presets are files of these).

A preset (a file in ``tognet/collect/presets/``, named in :data:`PRESETS`) is a :class:`PipelineConfig`: how
many objects, how many trials in each round, how the policies explore and how long each round trains. Every
collection saves its :class:`CollectConfig` (and the simulator, task, crop and policy configs inside it)
beside its data.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Literal

from tognet.config import Config, ConfigError, ConfigRangeError, doc
from tognet.grasping.antipodal import AntipodalConfig
from tognet.grasping.crops import CropConfig
from tognet.io import short_digest
from tognet.model.config import TrainConfig
from tognet.objects.generate import GeneratorConfig
from tognet.policies.config import PolicyConfig
from tognet.sim.config import SimConfig

#: Names of the grasp and action policies a round can use.
RoundPolicy = Literal["nms_uniform", "epsilon_greedy", "search_candidates"]
#: Every round policy, and those that need the last round's task model (all but the first).
ROUND_POLICIES: tuple[str, ...] = ("nms_uniform", "epsilon_greedy", "search_candidates")
MODEL_POLICIES: tuple[str, ...] = ("epsilon_greedy", "search_candidates")


@dataclass(frozen=True)
class CollectConfig(Config):
    """One collection round's fixed settings (everything but the models and the number of trials)."""

    trials_per_scene: int = doc(
        8,
        "Trials run from one settled scene (state save/restore): a scene (drop, settle, depth image, "
        "candidates, model scores) costs about as much as one trial, so several trials share it.",
        ge=1,
    )
    scenes_per_job: int = doc(
        4,
        "Scenes in one job (one object, one shard). A job is the unit of work, of resumption and of loss "
        "when a worker dies: small enough to lose little, large enough that a shard is not tiny.",
        ge=1,
    )
    seed: int = doc(0, "Root seed: every scene and trial seed derives from (seed, task, round, job, scene).")
    sim: SimConfig = doc(factory=SimConfig, text="The simulated world and both tasks' set-ups.")
    antipodal: AntipodalConfig = doc(
        factory=lambda: AntipodalConfig(axis_direction="both"),
        text="Antipodal candidates; both jaw orientations, so a task scorer can choose which way round.",
    )
    crop: CropConfig = doc(factory=CropConfig, text="The network's crops (saved with the data).")
    policy: PolicyConfig = doc(factory=PolicyConfig, text="Exploration and the Gaussian policy.")

    def fingerprint(self) -> str:
        """A short hash of the config (stored with every shard, to refuse mixing settings on resume)."""
        text = json.dumps(self.to_dict(), sort_keys=True)
        return short_digest(text.encode())


@dataclass(frozen=True)
class RoundConfig(Config):
    """One round: how many trials, which policy, how long to train afterwards."""

    episodes: int = doc(1000, "Trials to run (rounded up to whole jobs).", ge=1)
    policy: RoundPolicy = doc(
        "nms_uniform",
        "'nms_uniform': NMS modes of the candidates ranked by grasp quality, uniform actions over the "
        "task's box (round 1); 'epsilon_greedy': CEM on the last model's Q_T and its action mean plus "
        "noise, with epsilon exploration (rounds 2+); 'search_candidates' (an action-search model only): "
        "the search's ``policy.search_candidates`` best candidates of each scene in turn, each with its "
        "searched action, with the same epsilon exploration (the grasps the search nearly chose: its "
        "hard negatives within a scene).",
    )
    epochs: int = doc(10, "Training epochs after the round (on all data so far, warm-started).", ge=1)
    expert_actions: float | None = doc(
        None, "Replaces ``collect.policy.expert_actions`` in this round (None: keep it).",
        ge=0, le=1,
    )

    def collect_config(self, config: CollectConfig) -> CollectConfig:
        """``config`` with this round's overrides applied (what the round runs with and saves)."""
        if self.expert_actions is None:
            return config
        return replace(config, policy=replace(config.policy, expert_actions=self.expert_actions))


@dataclass(frozen=True)
class PipelineConfig(Config):
    """A whole self-supervision run: objects, the grasp-only round, the task rounds and training."""

    name: str = doc("custom", "Preset name (ci, quick, paper, or your own).")
    objects: dict[str, int] = doc(
        factory=lambda: {"primitive": 20, "complex": 0},
        text="Training objects per kind (PG-Primitive, PG-Complex), generated into the run folder.",
    )
    grasp_round: RoundConfig = doc(
        factory=lambda: RoundConfig(episodes=1000, policy="nms_uniform", epochs=5),
        text="The grasp-only round (no primitive) that trains the task-agnostic Q_G model, our stand-in for "
        "the paper's GQ-CNN trained on Dex-Net data: round 1 ranks its candidates with it.",
    )
    rounds: tuple[RoundConfig, ...] = doc(
        (RoundConfig(policy="nms_uniform"), RoundConfig(policy="epsilon_greedy"),
         RoundConfig(policy="epsilon_greedy")),
        "The task rounds (the paper: 3 rounds of 500K trials; round 1 explores, then epsilon-greedy ones).",
    )
    task_rounds: dict[str, tuple[RoundConfig, ...]] = doc(
        factory=dict,
        text="Per-task replacement of ``rounds`` (e.g. more round-1 trials for hammering, whose random "
        "trials succeed ~40x less often than sweeping's).",
    )
    collect: CollectConfig = doc(factory=CollectConfig, text="Collection settings shared by every round.")
    train: TrainConfig = doc(
        factory=TrainConfig, text="Training settings (its epochs are replaced by each round's)."
    )
    task_train: dict[str, TrainConfig] = doc(
        factory=dict,
        text="Per-task replacement of ``train`` (a whole TrainConfig; fields left out take their defaults).",
    )
    object_workers: int | None = doc(
        None, "Processes generating objects (None: the collection's worker count).",
        ge=0,
    )
    generator: GeneratorConfig | None = doc(
        None,
        "The generator of the training objects (e.g. the ``wide`` profile, tognet/objects/profiles; fields "
        "left out take their defaults); None: the default generator, the one the test sets use.",
        omit_default=True,
    )

    def check(self) -> None:
        """Object counts of known kinds, at least one object, and task rounds that can run in order (the
        first explores: an epsilon-greedy round needs the model of a round before it)."""
        for kind, count in self.objects.items():
            if kind not in ("primitive", "complex"):
                raise ConfigRangeError("PipelineConfig", "objects",
                                       f"has an unknown kind {kind!r} (primitive, complex)")
            if count < 0:
                raise ConfigRangeError("PipelineConfig", "objects",
                                       f"[{kind!r}] must be 0 or more, got {count}")
        if sum(self.objects.values()) < 1:
            raise ConfigRangeError("PipelineConfig", "objects", f"asks for no objects: {self.objects}")
        for name, rounds in (("rounds", self.rounds), *((f"task_rounds.{t}", r) for t, r in
                                                        self.task_rounds.items())):
            if not rounds:
                raise ConfigRangeError("PipelineConfig", name, "is empty: a task needs at least one round")
            if rounds[0].policy in MODEL_POLICIES:
                raise ConfigRangeError("PipelineConfig", name, f"starts with a {rounds[0].policy} round, "
                                       "which needs the model of a round before it; start with nms_uniform")

    def rounds_for(self, task: str) -> tuple[RoundConfig, ...]:
        """The rounds of ``task``."""
        return self.task_rounds.get(task, self.rounds)

    def train_for(self, task: str) -> TrainConfig:
        """The training settings of ``task``."""
        return self.task_train.get(task, self.train)


#: The shipped presets, smallest first: ``ci`` (the tests' toy loop), ``quick`` (the paper's method, ~1 h on
#: 2 cores for two tasks), ``quick-search`` (the learned action search's recipe), ``medium`` (that recipe
#: with twice the objects and six rounds: one task fits in 3 hours on 2 cores), ``medium-wide`` (``medium``
#: on training objects of the ``wide`` generator profile) and ``paper``.
PRESETS = ("ci", "quick", "quick-search", "medium", "medium-wide", "paper")
#: Where the presets' files are (shipped inside the package).
PRESETS_DIR = Path(__file__).resolve().parent / "presets"


def load_preset(name_or_path: str | Path) -> PipelineConfig:
    """A preset by name (one of :data:`PRESETS`, shipped in tognet/collect/presets) or a JSON file's path."""
    text = str(name_or_path)
    if text in PRESETS:
        return PipelineConfig.load(PRESETS_DIR / f"{text}.json")
    path = Path(text)
    if not path.is_file():
        if path.suffix.lower() == ".json" or "/" in text or path.is_dir():
            raise ConfigError(f"--preset {text}: {'is a folder, not' if path.is_dir() else 'no such'} preset "
                              f"file (a PipelineConfig JSON); or one of {', '.join(PRESETS)}")
        raise ConfigError(f"unknown preset {text!r}: use one of {', '.join(PRESETS)} or a JSON file's path")
    return PipelineConfig.load(path)
