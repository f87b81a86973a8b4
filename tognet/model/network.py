"""The TOG-Net three-stream network.

One shared trunk (a strided convolution then residual blocks with batch norm) is applied to both the
64 x 64 crop and its centre 32 x 32 (the *same* module, so the streams share low-level parameters). Each
stream has its own 1 x 1 bottleneck convolution, then a head that also sees the gripper depth z through a
small fully connected embedding:

- grasp stream (32 x 32 centre features + z)  -> logit of Q_G
- task stream  (64 x 64 features + z)         -> logit of Q_T|G
- action stream (64 x 64 features + z)        -> normalised action mean f(o, g) (4 values)

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
        self.task = Stream(c, big, arch, 1)
        self.action = Stream(c, big, arch, ACTION_DIM)
        # Input/output normalisation (set from training data by :meth:`set_normalization`).
        self.register_buffer("crop_mean", torch.zeros(()))
        self.register_buffer("crop_std", torch.ones(()))
        self.register_buffer("z_mean", torch.zeros(()))
        self.register_buffer("z_std", torch.ones(()))
        self.register_buffer("action_mean", torch.zeros(ACTION_DIM))
        self.register_buffer("action_std", torch.ones(ACTION_DIM))

    def set_normalization(self, stats: dict[str, object]) -> None:
        """Copy normalisation statistics (see :func:`normalization_from_data`) into the buffers."""
        for name in ("crop_mean", "crop_std", "z_mean", "z_std", "action_mean", "action_std"):
            buf = getattr(self, name)
            buf.copy_(torch.as_tensor(stats[name], dtype=buf.dtype).reshape(buf.shape))

    def normalization(self) -> dict[str, float | list[float]]:
        """The normalisation statistics as plain numbers."""
        return {
            name: getattr(self, name).detach().cpu().tolist()
            for name in ("crop_mean", "crop_std", "z_mean", "z_std", "action_mean", "action_std")
        }

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

    def forward(self, crop: torch.Tensor, z: torch.Tensor) -> dict[str, torch.Tensor]:
        """Returns ``q_g_logit`` (N,), ``q_tg_logit`` (N,) and ``action_norm`` (N, 4)."""
        crop = self.check_inputs(crop, z)
        x = (crop - self.crop_mean) / self.crop_std
        lo = (self.arch.crop_size - self.arch.center_size) // 2
        hi = lo + self.arch.center_size
        feat_big = self.trunk(x)
        feat_small = self.trunk(x[:, :, lo:hi, lo:hi].contiguous())
        z_e = self.z_embed(((z - self.z_mean) / self.z_std).unsqueeze(1))
        return {
            "q_g_logit": self.grasp(feat_small, z_e).squeeze(1),
            "q_tg_logit": self.task(feat_big, z_e).squeeze(1),
            "action_norm": self.action(feat_big, z_e),
        }

    def denormalize_action(self, action_norm: torch.Tensor) -> torch.Tensor:
        """Normalised action -> stored action units (m, m, m, rad)."""
        return action_norm * self.action_std + self.action_mean


def normalization_from_data(
    crop: torch.Tensor, z: torch.Tensor, action: torch.Tensor, task_success: torch.Tensor
) -> dict[str, object]:
    """Statistics of the training data: scalar crop and z mean/std; per-dim action mean/std computed over
    task successes (the only actions the loss fits), falling back to all episodes when there are fewer
    than two. Std-devs are floored at 1e-6."""
    ok = task_success > 0.5
    acts = action[ok] if int(ok.sum()) >= 2 else action
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
