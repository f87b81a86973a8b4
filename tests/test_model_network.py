import pytest
import torch

from tognet.model.config import ArchConfig
from tognet.model.network import TOGNet, fold_batchnorm


def _randomise_bn(model):
    g = torch.Generator().manual_seed(0)
    for mod in model.modules():
        if isinstance(mod, torch.nn.BatchNorm2d):
            mod.running_mean.copy_(torch.rand(mod.running_mean.shape, generator=g) - 0.5)
            mod.running_var.copy_(torch.rand(mod.running_var.shape, generator=g) + 0.5)
            mod.weight.data.copy_(torch.rand(mod.weight.shape, generator=g) + 0.5)


def test_shapes_and_shared_trunk():
    torch.manual_seed(0)
    model = TOGNet().eval()
    out = model(torch.randn(5, 64, 64), torch.rand(5))
    assert out["q_g_logit"].shape == (5,) and out["q_tg_logit"].shape == (5,)
    assert out["action_norm"].shape == (5, 4)
    # one trunk: every convolution of the trunk is used by all three heads
    conv = model.trunk.layers[0]
    loss = out["q_g_logit"].sum()
    loss.backward()
    assert conv.weight.grad is not None and conv.weight.grad.abs().sum() > 0
    model.zero_grad()
    model(torch.randn(5, 64, 64), torch.rand(5))["q_tg_logit"].sum().backward()
    assert conv.weight.grad.abs().sum() > 0
    assert model.grasp.bottleneck is not model.task.bottleneck is not model.action.bottleneck


def test_grasp_head_sees_only_centre_crop_and_z():
    torch.manual_seed(0)
    model = TOGNet().eval()
    _randomise_bn(model)
    crop, z = torch.randn(3, 64, 64), torch.rand(3)
    out = model(crop, z)
    changed = crop.clone()
    changed[:, :16, :] += 1.0  # outside the central 32 x 32
    changed[:, :, 50:] -= 1.0
    out2 = model(changed, z)
    assert torch.allclose(out["q_g_logit"], out2["q_g_logit"])
    assert not torch.allclose(out["q_tg_logit"], out2["q_tg_logit"])
    out3 = model(crop, z + 0.3)
    assert not torch.allclose(out["q_g_logit"], out3["q_g_logit"])


@pytest.mark.parametrize(
    ("crop_shape", "z_shape", "match"),
    [((4, 32, 32), (4,), "crop: expected shape"), ((4, 64, 64), (3,), "z: expected shape"),
     ((4, 2, 64, 64), (4,), "crop: expected shape"), ((64, 64), (1,), "crop: expected shape")],
)
def test_bad_shapes_raise_clear_errors(crop_shape, z_shape, match):
    model = TOGNet().eval()
    with pytest.raises(ValueError, match=match):
        model(torch.zeros(crop_shape), torch.zeros(z_shape))


def test_fold_batchnorm_matches_eval_outputs():
    torch.manual_seed(1)
    model = TOGNet(ArchConfig(block_channels=(16, 24), block_strides=(2, 2))).eval()
    _randomise_bn(model)
    model.set_normalization({"crop_mean": 0.01, "crop_std": 0.02, "z_mean": 0.8, "z_std": 0.1,
                             "action_mean": [0.0, 0.1, 0.2, 0.3], "action_std": [1.0, 2.0, 3.0, 4.0]})
    folded = fold_batchnorm(model)
    assert not any(isinstance(m, torch.nn.BatchNorm2d) for m in folded.modules())
    crop, z = 0.02 * torch.randn(7, 64, 64), 0.8 + 0.1 * torch.rand(7)
    with torch.no_grad():
        a, b = model(crop, z), folded(crop, z)
    for key in a:
        torch.testing.assert_close(a[key], b[key], rtol=1e-4, atol=1e-5)
