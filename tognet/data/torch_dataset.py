"""A torch ``Dataset`` over episode arrays, with a validation split by object (never by episode)."""

from __future__ import annotations

import numpy as np
import torch
from torch.utils.data import Dataset

from tognet.data.episodes import split_indices_by_object
from tognet.data.format import EpisodeArrays


class EpisodeDataset(Dataset):
    """Episodes as tensors: each item is a dict with ``crop`` (1, 64, 64), ``z`` (), ``action`` (4,),
    ``grasp_success`` () and ``task_success`` () (float32), plus ``index`` (position in the arrays)."""

    def __init__(self, episodes: EpisodeArrays) -> None:
        self.episodes = episodes
        self._crop = torch.from_numpy(np.ascontiguousarray(episodes.crop, dtype=np.float32))
        self._z = torch.from_numpy(episodes.z.astype(np.float32))
        self._action = torch.from_numpy(episodes.action.astype(np.float32))
        self._s_g = torch.from_numpy(episodes.grasp_success.astype(np.float32))
        self._s_t = torch.from_numpy(episodes.task_success.astype(np.float32))

    def __len__(self) -> int:
        return len(self.episodes)

    def __getitem__(self, i: int) -> dict[str, torch.Tensor]:
        return self.batch(torch.tensor([i]), squeeze=True)

    def batch(self, index: torch.Tensor, squeeze: bool = False) -> dict[str, torch.Tensor]:
        """Many items at once (fast path for training without a DataLoader)."""
        out = {
            "crop": self._crop[index].unsqueeze(1),
            "z": self._z[index],
            "action": self._action[index],
            "grasp_success": self._s_g[index],
            "task_success": self._s_t[index],
            "index": index,
        }
        if squeeze:
            out = {k: v[0] for k, v in out.items()}
        return out

    def split_by_object(self, val_fraction: float, seed: int) -> tuple[EpisodeDataset, EpisodeDataset]:
        """(train, validation) datasets that share no object id."""
        train_idx, val_idx = split_indices_by_object(self.episodes.object_id, val_fraction, seed)
        return EpisodeDataset(self.episodes.subset(train_idx)), EpisodeDataset(self.episodes.subset(val_idx))
