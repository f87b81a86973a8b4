"""Configs of the TOG-Net model: architecture, loss and training (saved inside every checkpoint)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

from tognet.config import Config, doc
from tognet.grasping.crops import CropConfig


@dataclass(frozen=True)
class ArchConfig(Config):
    """Architecture hyperparameters of the three-stream network (small enough for a 2-core CPU)."""

    stem_channels: int = doc(16, "Channels of the first (strided) convolution of the shared trunk.")
    stem_kernel: int = doc(8, "Kernel size of the first convolution (padding (kernel - stride) / 2).")
    stem_stride: int = doc(4, "Stride of the first convolution (4: 64 x 64 -> 16 x 16; cheap on a CPU).")
    stem_pool: bool = doc(False, "2x2 max-pool after the first convolution.")
    block_channels: tuple[int, ...] = doc((32, 32), "Output channels of each shared residual block.")
    block_strides: tuple[int, ...] = doc((2, 1), "Stride of each shared residual block (same length).")
    bottleneck_channels: int = doc(8, "Channels of each stream's 1x1 bottleneck convolution.")
    z_features: int = doc(16, "Width of the small fully connected layer that embeds the gripper depth z.")
    head_hidden: int = doc(64, "Hidden units of each head's fully connected layer.")
    crop_size: int = doc(CropConfig().size, "Side of the large crop (Q_T|G and action streams), pixels: the "
                         "CropConfig's size (the data's crops).")
    center_size: int = doc(CropConfig().center_size, "Side of the centre crop (Q_G stream), pixels; sliced "
                           "from the large crop: the CropConfig's center_size.")
    task_head: Literal["policy", "action"] = doc(
        "policy",
        "'policy': the paper's task stream, Q_T|G from (crop, z) alone: the chance of success with the "
        "collection policy's action. 'action': the task stream also sees the action, Q_T|G,a (and the "
        "task's graded outcome), trained on every trial, so a grasp can be rated by the best action it "
        "allows and a planner can search the action (the learned action search, beyond the paper).",
    )
    action_features: int = doc(32, "Width of the action embedding of an action-conditioned task stream.")
    action_members: int = doc(
        1,
        "Members of the action-conditioned task stream (an ensemble sharing the trunk and bottleneck, each "
        "its own head from its own initialisation): their spread says where the data is thin, so a search "
        "can prefer actions they agree on (ActionSearchConfig.pessimism).",
    )
    action_hidden: int = doc(
        128,
        "Hidden units of an action-conditioned task stream's head (two layers); wider than the other "
        "heads: it must tell, for one grasp, the actions that work from those that do not.",
    )


@dataclass(frozen=True)
class LossConfig(Config):
    """The paper's objective: CE(S_G,Q_G) + 1[S_G=1] CE(S_T,Q_T|G) + 1[S_T=1] 1/2 ||f - a||^2_Sigma."""

    action_sigma: tuple[float, float, float, float] = doc(
        (0.03, 0.03, 0.03, 0.09),
        "Diagonal of the constant policy std-dev Sigma^(1/2) per action dim (m, m, m, rad); the default is "
        "about the std-dev of the uniform random actions (+-5 cm, +-pi/20), so the term is of order one.",
    )
    action_sigma_source: Literal["fixed", "data"] = doc(
        "fixed",
        "'fixed': Sigma^(1/2) is ``action_sigma``. 'data': it is the per-dimension std-dev of the training "
        "data's successful actions (the network's action normalisation, kept by warm-started rounds), so "
        "that each dimension's term is of order one whatever the spread of the actions that succeed: with "
        "``action_sigma`` far below that spread the action term outweighs the two cross-entropies many "
        "times over and the shared layers learn little else.",
    )
    reduction: Literal["batch", "masked"] = doc(
        "batch",
        "'batch': every term summed over its masked episodes and divided by the batch size N (the paper's "
        "sum over episodes, scaled by 1/N). 'masked': each term averaged over its own masked subset "
        "(an empty subset contributes 0).",
    )
    weight_grasp: float = doc(1.0, "Weight of the Q_G cross-entropy term (1 = the paper).", ge=0)
    weight_task: float = doc(1.0, "Weight of the Q_T|G cross-entropy term (1 = the paper).", ge=0)
    weight_action: float = doc(1.0, "Weight of the action term (1 = the paper).", ge=0)
    weight_progress: float = doc(
        0.5,
        "Weight of the graded-outcome term of an action-conditioned task stream (cross-entropy of the "
        "predicted progress against the trial's progress in [0, 1], over trials that held the tool and "
        "whose task grades): a trial that nearly worked says more than a bare 0. Unused by the paper's "
        "model.",
        ge=0,
    )
    max_lift_tilt: float = doc(
        0.0,
        "Beyond the paper: a grasp whose tool swung more than this (rad) in the fingers when lifted (the "
        "trial's lift_tilt) is labelled a failed grasp for Q_G, and its trial is left out of the task "
        "stream, as for any failed grasp. A tool held far off balance swings and lands the task elsewhere "
        "than the image says. 0: off (the paper's label, held clear of the table).",
        ge=0, omit_default=True,
    )
    weight_rank: float = doc(
        0.0,
        "Weight of the within-scene ranking term (beyond the paper): over every pair of trials of one scene "
        "where one did the task and the other did not, the logistic loss of the difference of their log "
        "Q_G * Q_T|G (the score a planner ranks a scene's candidates by), averaged over the batch's pairs. "
        "Batches are then made of whole scenes. 0: off.",
        ge=0, omit_default=True,
    )


@dataclass(frozen=True)
class TrainConfig(Config):
    """Training of one TOG-Net model (one per task)."""

    arch: ArchConfig = doc(factory=ArchConfig, text="Network architecture.")
    loss: LossConfig = doc(factory=LossConfig, text="Loss definition.")
    epochs: int = doc(30, "Maximum number of passes over the training episodes.", ge=1)
    batch_size: int = doc(128, "Episodes per optimisation step.", ge=1)
    lr: float = doc(1e-3, "Adam learning rate (0: no updates).", ge=0)
    weight_decay: float = doc(1e-4, "Adam (L2) weight decay.", ge=0)
    lr_decay: float = doc(0.95, "Learning rate multiplied by this after every epoch.", gt=0, le=1)
    val_fraction: float = doc(
        0.1, "Fraction of the *objects* held out for validation (never split by episode).",
        ge=0, lt=1,
    )
    patience: int = doc(5, "Early stopping: epochs without a better validation loss before stopping.", ge=1)
    monitor: Literal["loss", "classification"] = doc(
        "loss",
        "What early stopping and the best checkpoint watch on the validation objects: 'loss' (the whole "
        "objective, the paper's) or 'classification' (the Q_G and Q_T|G cross-entropies only): when the "
        "action term dominates the loss, 'loss' stops as soon as the action regression stalls, before the "
        "task classifier has learnt.",
    )
    min_delta: float = doc(1e-4, "Early stopping: smallest decrease of validation loss that counts.", ge=0)
    seed: int = doc(0, "Seed of weight initialisation, batch order and the validation split.")
    num_threads: int = doc(
        1,
        "torch CPU threads (fixed, for determinism). 1 by default: on a 2-core machine shared with data "
        "collection, 2 threads slowed training steps several-fold; use 2 on an idle machine.",
        ge=1,
    )
    deterministic: bool = doc(True, "torch.use_deterministic_algorithms(True) (CPU runs are reproducible).")
    device: str = doc("auto", "'auto' (CUDA when available, else CPU), 'cpu' or 'cuda'.")
    eval_batch_size: int = doc(1024, "Episodes per forward pass during validation.", ge=1)
    crop_storage: Literal["float32", "float16"] = doc(
        "float32",
        "Deprecated and ignored (kept so that existing config files still load): training streams the "
        "data and holds only the shuffle buffer, whose crops stay float16 as stored on disk; batches are "
        "computed in float32.",
    )
    shuffle_buffer: int = doc(
        16384,
        "Training episodes held in memory to shuffle batches (8 KiB each: 16384 = 128 MiB, whatever the "
        "dataset size). Shards are visited in a random order every epoch and each batch is drawn at random "
        "from the buffer; collected shards hold one object each, so the buffer must span many shards.",
        ge=1,
    )
    skip_bad_shards: bool = doc(False, "Skip corrupt or truncated shards with a warning instead of failing.")
