"""Subnormal weights are flushed to zero in the predictor's inference copy, its outputs unchanged."""

import numpy as np
import torch

from tognet.model.config import ArchConfig
from tognet.model.network import TOGNet, flush_subnormal
from tognet.model.predict import TOGNetPredictor


def _with_subnormals() -> TOGNet:
    """An action-conditioned model, a tenth of its linear weights set to subnormal values (as weight decay
    leaves them after a long training run)."""
    torch.manual_seed(3)
    model = TOGNet(ArchConfig(task_head="action")).eval()
    g = torch.Generator().manual_seed(0)
    with torch.no_grad():
        for mod in model.modules():
            if isinstance(mod, torch.nn.Linear):
                pick = torch.rand(mod.weight.shape, generator=g) < 0.1
                mod.weight[pick] = 1e-40 * torch.sign(torch.randn(int(pick.sum()), generator=g))
    return model


def test_flush_subnormal_counts_and_zeroes():
    model = _with_subnormals()
    linear = [m.weight for m in model.modules() if isinstance(m, torch.nn.Linear)]
    tiny = torch.finfo(torch.float32).tiny
    expected = sum(int(((w != 0) & (w.abs() < tiny)).sum()) for w in linear)
    assert expected > 0
    assert flush_subnormal(model) == expected
    assert flush_subnormal(model) == 0
    assert all(not bool(((w != 0) & (w.abs() < tiny)).any()) for w in linear)


def test_predictor_flushes_its_copy_and_scores_alike():
    model = _with_subnormals()
    before = {k: v.clone() for k, v in model.state_dict().items()}
    flushed = TOGNetPredictor(model, device="cpu", optimize=False)
    assert flushed.flushed_subnormal > 0
    for k, v in model.state_dict().items():  # the caller's model is left alone
        assert torch.equal(v, before[k]), k
    rng = np.random.default_rng(0)
    crops = rng.normal(0.0, 0.02, size=(6, 64, 64)).astype(np.float32)
    z = rng.uniform(0.6, 1.0, size=6).astype(np.float32)
    actions = rng.normal(0.0, 1.0, size=(6, 9, 4))
    enc = flushed.encode(crops, z)
    scores = flushed.score_actions(enc, actions)
    with torch.inference_mode():
        ref = model.encode_task(torch.from_numpy(crops), torch.from_numpy(z))
        logits = model.score_actions(ref["encoded"], torch.from_numpy(actions.astype(np.float32)))
    torch.testing.assert_close(enc.encoded, ref["encoded"], rtol=1e-5, atol=1e-6)
    np.testing.assert_allclose(scores.success, torch.sigmoid(logits[..., 0]).mean(dim=2).numpy(),
                               rtol=1e-5, atol=1e-6)
