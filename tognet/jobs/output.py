"""What a job sends back to its coordinator."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from numpy.typing import NDArray


@dataclass
class JobOutput:
    """What a job sends back: its records (columns, possibly empty), counters and any error."""

    job: int
    columns: dict[str, NDArray[Any]]
    stats: dict[str, Any] = field(default_factory=dict)
    error: str | None = None
