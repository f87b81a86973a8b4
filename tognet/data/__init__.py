"""Episode records: shard writer and reader, the torch Dataset and the split by object.

``tognet.data.episodes`` needs only numpy (collection workers import it); the torch Dataset lives in
``tognet.data.torch_dataset``.
"""

from tognet.data.episodes import (
    FAILURE_CODES,
    FIELDS,
    FORMAT_VERSION,
    DatasetError,
    EpisodeArrays,
    ShardWriter,
    describe_dataset,
    failure_code,
    read_dataset,
    read_shard,
    shard_paths,
    split_indices_by_object,
)

__all__ = [
    "FAILURE_CODES",
    "FIELDS",
    "FORMAT_VERSION",
    "DatasetError",
    "EpisodeArrays",
    "ShardWriter",
    "describe_dataset",
    "failure_code",
    "read_dataset",
    "read_shard",
    "shard_paths",
    "split_indices_by_object",
    "EpisodeDataset",
]


def __getattr__(name: str) -> object:
    if name == "EpisodeDataset":
        from tognet.data.torch_dataset import EpisodeDataset

        return EpisodeDataset
    raise AttributeError(name)
