"""What one object is on disk, and the catalog of a set of objects.

A set folder holds ``catalog.json`` and one sub-folder per object::

    <set>/catalog.json
    <set>/<object_id>/collision_00.obj ...   convex pieces (object frame, metres), for collision
    <set>/<object_id>/visual.obj             the watertight whole, for rendering and mass properties
    <set>/<object_id>/object.xml             an MJCF model MuJoCo loads directly (body "object", free joint)

The object frame is the frame the meshes are written in; ``com`` and ``inertia`` are expressed in it.
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from tognet.errors import TognetError

CATALOG_NAME = "catalog.json"
CATALOG_VERSION = 1
KINDS = ("primitive", "complex", "realistic", "imported")
SPLITS = ("train", "test")


class CatalogError(TognetError):
    """A catalog or object folder is missing, malformed or inconsistent."""


@dataclass(frozen=True)
class ObjectRecord:
    """One tool object: identity, composition and physical properties (SI units, object frame)."""

    object_id: str
    kind: str
    split: str
    shape_rule: str
    part_types: list[str]
    extents: list[float]
    mass: float
    volume: float
    density: float
    friction: float
    com: list[float]
    inertia: list[list[float]]
    collision_meshes: list[str]
    visual_mesh: str
    mjcf: str
    folder: str = field(default="", compare=False)
    extra: dict[str, Any] = field(default_factory=dict)

    def path(self, name: str) -> Path:
        """Absolute path of a file of this object (``name`` as stored in the record)."""
        return Path(self.folder) / name

    @property
    def collision_paths(self) -> list[Path]:
        """Absolute paths of the convex collision pieces."""
        return [self.path(n) for n in self.collision_meshes]

    @property
    def mjcf_path(self) -> Path:
        """Absolute path of the object's standalone MJCF file."""
        return self.path(self.mjcf)

    @property
    def inertia_matrix(self) -> NDArray[np.float64]:
        """3x3 inertia tensor about the centre of mass, object frame (kg m^2)."""
        return np.asarray(self.inertia, dtype=np.float64)

    def to_json(self) -> dict[str, Any]:
        """The record as catalog JSON (``folder`` is stored relative to the set folder)."""
        data = asdict(self)
        data["folder"] = self.object_id
        return data


def object_from_json(data: dict[str, Any], set_dir: Path) -> ObjectRecord:
    """Build a record from catalog JSON; paths resolve against ``set_dir``."""
    try:
        data = dict(data)
        data["folder"] = str((set_dir / data.get("folder", data["object_id"])).resolve())
        return ObjectRecord(**data)
    except TypeError as exc:
        raise CatalogError(f"{set_dir / CATALOG_NAME}: malformed object entry ({exc})") from exc
    except KeyError as exc:
        raise CatalogError(f"{set_dir / CATALOG_NAME}: object entry without {exc}") from exc


def write_catalog(
    set_dir: str | Path, records: list[ObjectRecord], meta: dict[str, Any] | None = None
) -> Path:
    """Write ``catalog.json`` for a set (records sorted by id, so the file is deterministic)."""
    set_dir = Path(set_dir)
    set_dir.mkdir(parents=True, exist_ok=True)
    payload = {
        "catalog_version": CATALOG_VERSION,
        "meta": meta or {},
        "objects": [r.to_json() for r in sorted(records, key=lambda r: r.object_id)],
    }
    path = set_dir / CATALOG_NAME
    tmp = path.with_suffix(".json.tmp")
    tmp.write_text(json.dumps(payload, indent=1) + "\n")
    tmp.replace(path)
    return path


def load_catalog(set_dir: str | Path) -> list[ObjectRecord]:
    """All records of a set folder, checking that every file they name exists."""
    set_dir = Path(set_dir)
    path = set_dir / CATALOG_NAME
    if not path.is_file():
        raise CatalogError(f"no object catalog at {path} (generate one with `tognet objects generate`)")
    try:
        payload = json.loads(path.read_text())
    except json.JSONDecodeError as exc:
        raise CatalogError(f"{path}: not valid JSON ({exc})") from exc
    if payload.get("catalog_version") != CATALOG_VERSION:
        found = payload.get("catalog_version")
        raise CatalogError(f"{path}: catalog version {found} is not {CATALOG_VERSION}")
    records = [object_from_json(entry, set_dir) for entry in payload.get("objects", [])]
    for record in records:
        for name in [*record.collision_meshes, record.visual_mesh, record.mjcf]:
            if not record.path(name).is_file():
                raise CatalogError(f"object {record.object_id}: file {record.path(name)} is missing")
    return records


def load_object(set_dir: str | Path, object_id: str) -> ObjectRecord:
    """One record of a set by id; an unknown id raises CatalogError listing a few known ones."""
    records = load_catalog(set_dir)
    for record in records:
        if record.object_id == object_id:
            return record
    known = ", ".join(r.object_id for r in records[:5])
    raise CatalogError(f"no object '{object_id}' in {set_dir} (it has {len(records)}: {known}, ...)")
