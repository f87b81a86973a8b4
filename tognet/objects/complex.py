"""PG-Complex: parts cut by convex decomposition from generated irregular meshes (work in progress)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import trimesh

from tognet.config import Config, doc
from tognet.errors import TognetError
from tognet.objects.compose import ShapeRanges


@dataclass(frozen=True)
class ComplexConfig(Config):
    """How PG-Complex objects are drawn."""

    ranges: ShapeRanges = doc(factory=ShapeRanges, text="Part sizes, density, friction and rule weights.")


def make_complex(
    rng: np.random.Generator, config: ComplexConfig | None = None
) -> tuple[trimesh.Trimesh, list[trimesh.Trimesh], str, list[str], dict[str, Any]]:
    """Draw one PG-Complex object: (visual, convex pieces, rule, part types, info)."""
    raise TognetError("PG-Complex is not implemented yet")
