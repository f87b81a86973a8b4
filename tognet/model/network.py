"""The TOG-Net three-stream network.

One shared trunk (a strided convolution then residual blocks with batch norm) is applied to both the
64 x 64 crop and its centre 32 x 32 (the *same* module, so the streams share low-level parameters). Each
stream has its own 1 x 1 bottleneck convolution, then a head that also sees the gripper depth z through a
small fully connected embedding:

- grasp stream (32 x 32 centre features + z)  -> logit of Q_G
- task stream  (64 x 64 features + z)         -> logit of Q_T|G
- action stream (64 x 64 features + z)        -> normalised action mean f(o, g) (4 values)

With ``ArchConfig.task_head = "action"`` (the learned action search, beyond the paper) the task stream
also sees an action a: its first layer adds an embedding of a to the grasp's features, so the grasp's
part is computed once and many actions are scored for it cheaply (:meth:`TOGNet.encode_task`,
:meth:`TOGNet.score_actions`). It predicts the logit of Q_T|G,a and the logit of the task's graded outcome
(progress); without an action given, it scores the network's own action mean.

Inputs are raw crops (depth minus gripper depth, metres) and z (metres); the normalisation statistics
computed from the training data live in buffers, so a state dict carries them.
"""

from __future__ import annotations

import torch
from torch import nn

from tognet.model.config import ArchConfig

ACTION_DIM = 4


class ResBlock(nn.Module):
    """Two 3 x 3 convolutions with batch norm and a (projected if needed) identity shortcut."""

    def __init__(self, cin: int, cout: int, stride: int) -> None:
        super().__init__()
        self.conv1 = nn.Conv2d(cin, cout, 3, stride=stride, padding=1, bias=False)
        self.bn1 = nn.BatchNorm2d(cout)
        self.conv2 = nn.Conv2d(cout, cout, 3, padding=1, bias=False)
        self.bn2 = nn.BatchNorm2d(cout)
        self.relu = nn.ReLU(inplace=True)
        self.shortcut: nn.Module = nn.Identity()
        if stride != 1 or cin != cout:
            self.shortcut = nn.Sequential(
                nn.Conv2d(cin, cout, 1, stride=stride, bias=False), nn.BatchNorm2d(cout)
            )

    def forward(self, x: torch.Tensor) -> torch.Tensor:  # noqa: D102
        y = self.relu(self.bn1(self.conv1(x)))
        y = self.bn2(self.conv2(y))
        return self.relu(y + self.shortcut(x))


class Trunk(nn.Module):
    """The shared low-level convolutional layers."""

    def __init__(self, arch: ArchConfig) -> None:
        super().__init__()
        if len(arch.block_channels) != len(arch.block_strides):
            raise ValueError("arch.block_channels and arch.block_strides must have the same length")
        layers: list[nn.Module] = [
            nn.Conv2d(1, arch.stem_channels, arch.stem_kernel, stride=arch.stem_stride,
                      padding=max(arch.stem_kernel - arch.stem_stride, 0) // 2, bias=False),
            nn.BatchNorm2d(arch.stem_channels),
            nn.ReLU(inplace=True),
        ]
        if arch.stem_pool:
            layers.append(nn.MaxPool2d(2))
        cin = arch.stem_channels
        for cout, stride in zip(arch.block_channels, arch.block_strides, strict=True):
            layers.append(ResBlock(cin, cout, stride))
            cin = cout
        self.layers = nn.Sequential(*layers)
        self.out_channels = cin

    def forward(self, x: torch.Tensor) -> torch.Tensor:  # noqa: D102
        return self.layers(x)


class Stream(nn.Module):
    """A 1 x 1 bottleneck on trunk features, concatenated with the z embedding, then a two-layer head."""

    def __init__(self, cin: int, spatial: int, arch: ArchConfig, out: int) -> None:
        super().__init__()
        b = arch.bottleneck_channels
        self.bottleneck = nn.Sequential(
            nn.Conv2d(cin, b, 1, bias=False), nn.BatchNorm2d(b), nn.ReLU(inplace=True)
        )
        self.head = nn.Sequential(
            nn.Linear(b * spatial * spatial + arch.z_features, arch.head_hidden),
            nn.ReLU(inplace=True),
            nn.Linear(arch.head_hidden, out),
        )

    def forward(self, features: torch.Tensor, z_embed: torch.Tensor) -> torch.Tensor:  # noqa: D102
        x = self.bottleneck(features).flatten(1)
        return self.head(torch.cat([x, z_embed], dim=1))


class _ActionMember(nn.Module):
    """One member of the action-conditioned task stream: the grasp's part, the action's part, the head."""

    def __init__(self, features: int, arch: ArchConfig) -> None:
        super().__init__()
        h = arch.action_hidden
        self.grasp_part = nn.Linear(features, h)
        self.action_part = nn.Sequential(
            nn.Linear(ACTION_DIM, arch.action_features), nn.ReLU(inplace=True),
            nn.Linear(arch.action_features, h, bias=False),
        )
        self.head = nn.Sequential(nn.ReLU(), nn.Linear(h, h), nn.ReLU(), nn.Linear(h, 2))

    def score(self, encoded: torch.Tensor, action_norm: torch.Tensor) -> torch.Tensor:
        a = self.action_part(action_norm)
        return self.head(encoded + a if a.dim() == 2 else encoded.unsqueeze(1) + a)


class ActionTaskStream(nn.Module):
    """The action-conditioned task stream: bottleneck features and z (one part per grasp) plus an action
    embedding (one part per action) -> two logits (task success, progress) per (grasp, action) pair, from
    each of ``ArchConfig.action_members`` members (an ensemble on one bottleneck: where they disagree, the
    model has not seen enough, and a search can hold back there)."""

    def __init__(self, cin: int, spatial: int, arch: ArchConfig) -> None:
        super().__init__()
        b = arch.bottleneck_channels
        self.bottleneck = nn.Sequential(
            nn.Conv2d(cin, b, 1, bias=False), nn.BatchNorm2d(b), nn.ReLU(inplace=True)
        )
        features = b * spatial * spatial + arch.z_features
        if arch.action_members < 1:
            raise ValueError(f"arch.action_members must be >= 1, got {arch.action_members}")
        self.members = nn.ModuleList(_ActionMember(features, arch) for _ in range(arch.action_members))

    def encode(self, features: torch.Tensor, z_embed: torch.Tensor) -> torch.Tensor:
        """Each member's grasp part of its first layer (N, members, hidden)."""
        x = torch.cat([self.bottleneck(features).flatten(1), z_embed], dim=1)
        return torch.stack([m.grasp_part(x) for m in self.members], dim=1)

    def score(self, encoded: torch.Tensor, action_norm: torch.Tensor) -> torch.Tensor:
        """Logits (..., members, 2) for normalised actions: ``encoded`` (N, members, H) with actions (N, 4)
        or (N, K, 4)."""
        return torch.stack([m.score(encoded[:, i], action_norm) for i, m in enumerate(self.members)], dim=-2)


class TOGNet(nn.Module):
    """Predicts logits of Q_G and Q_T|G and the normalised action mean from (crop, z)."""

    def __init__(self, arch: ArchConfig | None = None) -> None:
        super().__init__()
        self.arch = arch = arch or ArchConfig()
        if not 0 < arch.center_size <= arch.crop_size or (arch.crop_size - arch.center_size) % 2:
            raise ValueError(f"bad crop sizes {arch.crop_size} / {arch.center_size}")
        self.trunk = Trunk(arch)
        with torch.no_grad():
            self.trunk.eval()
            big = self.trunk(torch.zeros(1, 1, arch.crop_size, arch.crop_size)).shape[-1]
            small = self.trunk(torch.zeros(1, 1, arch.center_size, arch.center_size)).shape[-1]
            self.trunk.train()
        c = self.trunk.out_channels
        self.z_embed = nn.Sequential(nn.Linear(1, arch.z_features), nn.ReLU(inplace=True))
        self.grasp = Stream(c, small, arch, 1)
        self.task: nn.Module = (ActionTaskStream(c, big, arch) if arch.task_head == "action"
                                else Stream(c, big, arch, 1))
        self.action = Stream(c, big, arch, ACTION_DIM)
        # Input/output normalisation (set from training data by :meth:`set_normalization`).
        self.register_buffer("crop_mean", torch.zeros(()))
        self.register_buffer("crop_std", torch.ones(()))
        self.register_buffer("z_mean", torch.zeros(()))
        self.register_buffer("z_std", torch.ones(()))
        self.register_buffer("action_mean", torch.zeros(ACTION_DIM))
        self.register_buffer("action_std", torch.ones(ACTION_DIM))
        if arch.task_head == "action":  # the task stream's action input: spread of every tried action
            self.register_buffer("action_in_mean", torch.zeros(ACTION_DIM))
            self.register_buffer("action_in_std", torch.ones(ACTION_DIM))

    def _stat_names(self) -> tuple[str, ...]:
        names = ("crop_mean", "crop_std", "z_mean", "z_std", "action_mean", "action_std")
        return (*names, "action_in_mean", "action_in_std") if self.arch.task_head == "action" else names

    def set_normalization(self, stats: dict[str, object]) -> None:
        """Copy normalisation statistics (see :func:`normalization_from_data`) into the buffers."""
        for name in self._stat_names():
            buf = getattr(self, name)
            buf.copy_(torch.as_tensor(stats[name], dtype=buf.dtype).reshape(buf.shape))

    def normalization(self) -> dict[str, float | list[float]]:
        """The normalisation statistics as plain numbers."""
        return {name: getattr(self, name).detach().cpu().tolist() for name in self._stat_names()}

    def check_inputs(self, crop: torch.Tensor, z: torch.Tensor) -> torch.Tensor:
        """Validate shapes; returns crop as (N, 1, S, S). ValueError names the bad input and shape."""
        s = self.arch.crop_size
        if crop.dim() == 3:
            crop = crop.unsqueeze(1)
        if crop.dim() != 4 or tuple(crop.shape[1:]) != (1, s, s):
            raise ValueError(
                f"crop: expected shape (N, {s}, {s}) or (N, 1, {s}, {s}), got {tuple(crop.shape)}"
            )
        if z.dim() != 1 or z.shape[0] != crop.shape[0]:
            raise ValueError(f"z: expected shape ({crop.shape[0]},) to match the crops, got {tuple(z.shape)}")
        return crop

    @property
    def action_conditioned(self) -> bool:
        """Whether the task stream sees the action (``ArchConfig.task_head == "action"``)."""
        return self.arch.task_head == "action"

    def _features(self, crop: torch.Tensor, z: torch.Tensor
                  ) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        crop = self.check_inputs(crop, z)
        x = (crop - self.crop_mean) / self.crop_std
        lo = (self.arch.crop_size - self.arch.center_size) // 2
        hi = lo + self.arch.center_size
        feat_big = self.trunk(x)
        feat_small = self.trunk(x[:, :, lo:hi, lo:hi].contiguous())
        z_e = self.z_embed(((z - self.z_mean) / self.z_std).unsqueeze(1))
        return feat_big, feat_small, z_e

    def forward(self, crop: torch.Tensor, z: torch.Tensor, action: torch.Tensor | None = None
                ) -> dict[str, torch.Tensor]:
        """Returns ``q_g_logit`` (N,), ``q_tg_logit`` (N,) and ``action_norm`` (N, 4); an action-conditioned
        model also ``progress_logit`` (N,), both for ``action`` (N, 4, stored units) or, when None, for its
        own action mean, and both (N, members) with several members. The paper's model ignores
        ``action``."""
        feat_big, feat_small, z_e = self._features(crop, z)
        action_norm = self.action(feat_big, z_e)
        out = {"q_g_logit": self.grasp(feat_small, z_e).squeeze(1), "action_norm": action_norm}
        if isinstance(self.task, ActionTaskStream):
            a = self.normalize_action(self.denormalize_action(action_norm.detach()) if action is None
                                      else action)
            logits = self.task.score(self.task.encode(feat_big, z_e), a)  # (N, members, 2)
            squeeze = logits.shape[1] == 1
            out["q_tg_logit"] = logits[:, 0, 0] if squeeze else logits[..., 0]
            out["progress_logit"] = logits[:, 0, 1] if squeeze else logits[..., 1]
        else:
            out["q_tg_logit"] = self.task(feat_big, z_e).squeeze(1)
        return out

    def encode_task(self, crop: torch.Tensor, z: torch.Tensor) -> dict[str, torch.Tensor]:
        """For an action-conditioned model: ``q_g_logit`` (N,), ``action_norm`` (N, 4) and ``encoded``
        (N, members, H), the grasp's part of the task stream, to score many actions with
        :meth:`score_actions`."""
        if not isinstance(self.task, ActionTaskStream):
            raise ValueError("this model's task stream does not see the action (ArchConfig.task_head)")
        feat_big, feat_small, z_e = self._features(crop, z)
        return {"q_g_logit": self.grasp(feat_small, z_e).squeeze(1),
                "action_norm": self.action(feat_big, z_e), "encoded": self.task.encode(feat_big, z_e)}

    def score_actions(self, encoded: torch.Tensor, actions: torch.Tensor) -> torch.Tensor:
        """Logits (N, K, members, 2) (task success, progress) of actions (N, K, 4, stored units) for encoded
        grasps."""
        assert isinstance(self.task, ActionTaskStream)
        return self.task.score(encoded, self.normalize_action(actions))

    def normalize_action(self, action: torch.Tensor) -> torch.Tensor:
        """Stored action units (m, m, m, rad) -> the action-conditioned task stream's input (normalised
        by the spread of every action tried, not only of the successful ones the mean head fits)."""
        return (action - self.action_in_mean) / self.action_in_std

    def denormalize_action(self, action_norm: torch.Tensor) -> torch.Tensor:
        """Normalised action -> stored action units (m, m, m, rad)."""
        return action_norm * self.action_std + self.action_mean


def normalization_from_data(
    crop: torch.Tensor, z: torch.Tensor, action: torch.Tensor, task_success: torch.Tensor
) -> dict[str, object]:
    """Statistics of the training data: scalar crop and z mean/std; per-dim action mean/std computed over
    task successes (the only actions the loss fits), falling back to all episodes when there are fewer
    than two; per-dim mean/std of every action (the input of an action-conditioned task stream).
    Std-devs are floored at 1e-6."""
    ok = task_success > 0.5
    acts = action[ok] if int(ok.sum()) >= 2 else action
    every = action if action.shape[0] >= 2 else torch.zeros(2, ACTION_DIM)
    if acts.shape[0] >= 2:
        a_mean, a_std = acts.mean(0), acts.std(0)
    else:
        a_mean, a_std = torch.zeros(ACTION_DIM), torch.ones(ACTION_DIM)
    c = crop.double()
    return {
        "crop_mean": float(c.mean()),
        "crop_std": max(float(c.std()), 1e-6),
        "z_mean": float(z.double().mean()),
        "z_std": max(float(z.double().std()), 1e-6) if z.numel() > 1 else 1.0,
        "action_mean": a_mean.tolist(),
        "action_std": a_std.clamp_min(1e-6).tolist(),
        "action_in_mean": every.mean(0).tolist(),
        "action_in_std": every.std(0).clamp_min(1e-6).tolist(),
    }


def fold_batchnorm(model: TOGNet) -> TOGNet:
    """A copy of ``model`` for inference with every BatchNorm folded into the convolution before it.

    Outputs equal the eval-mode outputs of ``model`` up to float rounding; the copy is in eval mode and
    must not be trained.
    """
    import copy

    from torch.nn.utils.fusion import fuse_conv_bn_eval

    folded = copy.deepcopy(model).eval()
    for module in folded.modules():
        if isinstance(module, ResBlock):
            module.conv1 = fuse_conv_bn_eval(module.conv1, module.bn1)
            module.bn1 = nn.Identity()  # type: ignore[assignment]
            module.conv2 = fuse_conv_bn_eval(module.conv2, module.bn2)
            module.bn2 = nn.Identity()  # type: ignore[assignment]
        if isinstance(module, nn.Sequential):
            children = list(module)
            for i in range(len(children) - 1):
                if isinstance(children[i], nn.Conv2d) and isinstance(children[i + 1], nn.BatchNorm2d):
                    module[i] = fuse_conv_bn_eval(children[i], children[i + 1])
                    module[i + 1] = nn.Identity()
    return folded


def flush_subnormal(model: nn.Module) -> int:
    """Set every subnormal value (0 < |w| < the smallest normal float) of ``model``'s floating-point
    parameters and buffers to zero, in place; returns how many there were. For inference copies only.

    Weight decay leaves the weights of unused units decaying towards zero, and a long training run takes
    many below float32's normal range (the shipped ``sweeping_search`` model has about 8,500 in its linear
    layers). A CPU multiplies by a subnormal in a slow microcode path, so a matrix product over such
    weights runs several times slower (the action search's scoring of 9,600 actions: 124 ms against 9 ms).
    A subnormal weight's products (around 1e-38 times an activation) vanish in the sums they join, so
    outputs are unchanged (bit for bit on the shipped models; what a CPU's denormals-are-zero mode would
    compute)."""
    count = 0
    with torch.no_grad():
        for tensor in (*model.parameters(), *model.buffers()):
            if not tensor.is_floating_point():
                continue
            sub = (tensor != 0) & (tensor.abs() < torch.finfo(tensor.dtype).tiny)
            count += int(sub.sum())
            tensor.masked_fill_(sub, 0.0)
    return count
