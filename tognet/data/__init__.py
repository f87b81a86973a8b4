"""Episode records: shard writer and reader, the torch Dataset and the split by object.

``tognet.data.episodes`` needs only numpy (collection workers import it); the torch Dataset lives in
``tognet.data.torch_dataset``.
"""

from tognet.data.episodes import (
    describe_dataset,
    read_dataset,
    read_shard,
    shard_paths,
    split_indices_by_object,
)
from tognet.data.format import (
    FAILURE_CODES,
    FIELDS,
    FORMAT_VERSION,
    DatasetError,
    EpisodeArrays,
    failure_code,
)
from tognet.data.writer import ShardWriter
from tognet.lazy_names import lazy_names

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
__getattr__, __dir__ = lazy_names(__name__, {"EpisodeDataset": "tognet.data.torch_dataset"})
