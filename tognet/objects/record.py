"""What one object is on disk, and the catalog of a set of objects.

A set folder holds ``catalog.json`` and one sub-folder per object::

    <set>/catalog.json
    <set>/catalog.csv                        the same table for spreadsheets (written, never read)
    <set>/<object_id>/collision_00.obj ...   convex pieces (object frame, metres), for collision
    <set>/<object_id>/visual.obj             the watertight whole, for rendering and mass properties
    <set>/<object_id>/object.xml             an MJCF model MuJoCo loads directly (body "object", free joint)

The object frame is the frame the meshes are written in; ``com`` and ``inertia`` are expressed in it.
"""

from __future__ import annotations

import csv
import io
import json
import math
from dataclasses import asdict, dataclass, field, fields
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from tognet.errors import TognetError
from tognet.io import atomic_write_text

CATALOG_NAME = "catalog.json"
CSV_NAME = "catalog.csv"
CSV_COLUMNS = (
    "id", "kind", "split", "shape_rule", "part_types", "extent_x", "extent_y", "extent_z", "mass", "volume",
    "density", "friction", "com_x", "com_y", "com_z", "pieces", "name",
)  # fmt: skip
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

    def load_mesh(self, name: str, watertight: bool = True) -> Any:
        """Load one of this object's mesh files as a trimesh; a damaged file raises CatalogError naming it."""
        import trimesh

        path = self.path(name)
        try:
            mesh = trimesh.load(path, force="mesh", process=False)
        except Exception as exc:  # trimesh raises many kinds of errors on broken files
            raise CatalogError(
                f"object {self.object_id}: cannot read {path}, damaged or truncated? "
                f"({type(exc).__name__}: {exc})"
            ) from None
        faces = np.asarray(getattr(mesh, "faces", np.zeros((0, 3))))
        vertices = np.asarray(getattr(mesh, "vertices", np.zeros((0, 3))))
        if len(faces) == 0 or len(vertices) == 0 or int(faces.max()) >= len(vertices):
            raise CatalogError(
                f"object {self.object_id}: {path} is empty or truncated; regenerate the object"
            )
        if watertight and not mesh.is_watertight:
            raise CatalogError(f"object {self.object_id}: {path} is not a closed surface (truncated?)")
        return mesh

    def check_meshes(self) -> None:
        """Read every mesh of the object (collision pieces, visual mesh): a damaged, empty or truncated one
        raises CatalogError naming its file (what MuJoCo would otherwise load silently, or fail on without
        saying which file)."""
        for name in [*self.collision_meshes, self.visual_mesh]:
            self.load_mesh(name)

    @property
    def file_names(self) -> list[str]:
        """Every file of the object's folder that building its world reads (collision pieces, the visual
        mesh, the MJCF), relative to ``folder``: what a cluster node needs of it."""
        return [*self.collision_meshes, self.visual_mesh, self.mjcf]

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


def _bad(set_dir: Path, index: int, what: str) -> CatalogError:
    return CatalogError(f"{set_dir / CATALOG_NAME}: object entry {index}: {what}")


def _number(value: Any) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)


def _check_entry(data: Any, set_dir: Path, index: int) -> None:
    """Raise CatalogError naming the entry and field if ``data`` is not a well-formed object entry."""
    if not isinstance(data, dict):
        raise _bad(set_dir, index, f"expected a JSON object, got {type(data).__name__}")
    required = [f.name for f in fields(ObjectRecord) if f.name not in ("folder", "extra")]
    missing = [name for name in required if name not in data]
    if missing:
        raise _bad(set_dir, index, f"missing field(s) {', '.join(missing)}")
    unknown = [k for k in data if k not in {f.name for f in fields(ObjectRecord)}]
    if unknown:
        raise _bad(set_dir, index, f"unknown field(s) {', '.join(unknown)}")
    oid = data["object_id"]
    if not isinstance(oid, str) or not oid or "/" in oid or "\\" in oid or oid.startswith("."):
        raise _bad(set_dir, index, f"object_id {oid!r} is not a plain folder name")
    for name in ("kind", "split", "shape_rule", "visual_mesh", "mjcf"):
        if not isinstance(data[name], str) or not data[name]:
            raise _bad(set_dir, index, f"{oid}: {name} must be a non-empty string, got {data[name]!r}")
    for name in ("part_types", "collision_meshes"):
        value = data[name]
        if not isinstance(value, list) or not value or not all(isinstance(v, str) and v for v in value):
            raise _bad(set_dir, index, f"{oid}: {name} must be a non-empty list of strings, got {value!r}")
    for name in ("mass", "volume", "density", "friction"):
        if not _number(data[name]) or data[name] <= 0:
            raise _bad(set_dir, index, f"{oid}: {name} must be a positive number, got {data[name]!r}")
    for name in ("extents", "com"):
        value = data[name]
        if not isinstance(value, list) or len(value) != 3 or not all(_number(v) for v in value):
            raise _bad(set_dir, index, f"{oid}: {name} must be 3 numbers, got {value!r}")
    inertia = data["inertia"]
    if not (
        isinstance(inertia, list)
        and len(inertia) == 3
        and all(isinstance(row, list) and len(row) == 3 and all(_number(v) for v in row) for row in inertia)
    ):
        raise _bad(set_dir, index, f"{oid}: inertia must be a 3x3 list of numbers, got {inertia!r}")
    for name in [*data["collision_meshes"], data["visual_mesh"], data["mjcf"]]:
        if "/" in name or "\\" in name or name.startswith("."):
            raise _bad(set_dir, index, f"{oid}: file name {name!r} must be a plain name in the object folder")
    if "extra" in data and not isinstance(data["extra"], dict):
        raise _bad(set_dir, index, f"{oid}: extra must be a JSON object, got {data['extra']!r}")


def object_from_json(data: Any, set_dir: Path, index: int = 0) -> ObjectRecord:
    """Build a record from catalog JSON (checked field by field); paths resolve against ``set_dir``."""
    _check_entry(data, set_dir, index)
    data = dict(data)
    folder = data.get("folder", data["object_id"])
    if not isinstance(folder, str) or "/" in folder or folder.startswith("."):
        raise _bad(set_dir, index, f"{data['object_id']}: folder {folder!r} is not a plain folder name")
    data["folder"] = str((set_dir / folder).resolve())
    return ObjectRecord(**data)


def _csv_number(value: float) -> str:
    return f"{float(value):.6g}"


def catalog_csv_text(records: list[ObjectRecord]) -> str:
    """The catalog as CSV (one row per object, sorted by id; SI units: m, kg, kg/m^3, m^3)."""
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(CSV_COLUMNS)
    for r in sorted(records, key=lambda r: r.object_id):
        extra = r.extra if isinstance(r.extra, dict) else {}
        name = extra.get("name") or extra.get("source") or ""
        writer.writerow(
            [
                r.object_id,
                r.kind,
                r.split,
                r.shape_rule,
                "+".join(r.part_types),
                *(_csv_number(v) for v in r.extents),
                _csv_number(r.mass),
                f"{float(r.volume):.6g}",
                _csv_number(r.density),
                _csv_number(r.friction),
                *(_csv_number(v) for v in r.com),
                len(r.collision_meshes),
                str(name),
            ]
        )
    return buffer.getvalue()


def write_catalog(
    set_dir: str | Path, records: list[ObjectRecord], meta: dict[str, Any] | None = None
) -> Path:
    """Write ``catalog.json`` and ``catalog.csv`` for a set (records sorted by id: deterministic bytes)."""
    set_dir = Path(set_dir)
    set_dir.mkdir(parents=True, exist_ok=True)
    payload = {
        "catalog_version": CATALOG_VERSION,
        "meta": meta or {},
        "objects": [r.to_json() for r in sorted(records, key=lambda r: r.object_id)],
    }
    path = set_dir / CATALOG_NAME
    atomic_write_text(path, json.dumps(payload, indent=1) + "\n", fsync=False)
    atomic_write_text(set_dir / CSV_NAME, catalog_csv_text(records), fsync=False)
    return path


def load_catalog(set_dir: str | Path) -> list[ObjectRecord]:
    """All records of a set folder, checking that every file they name exists."""
    set_dir = Path(set_dir)
    path = set_dir / CATALOG_NAME
    if not set_dir.exists():
        raise CatalogError(f"no such folder: {set_dir}")
    if not set_dir.is_dir():
        raise CatalogError(f"{set_dir} is a file, not an object set folder")
    if not path.is_file():
        raise CatalogError(f"no object catalog at {path} (generate one with `tognet objects generate`)")
    try:
        payload = json.loads(path.read_text())
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise CatalogError(f"{path}: not valid JSON ({exc})") from exc
    if not isinstance(payload, dict):
        raise CatalogError(f"{path}: expected a JSON object with 'objects', got a {type(payload).__name__}")
    if payload.get("catalog_version") != CATALOG_VERSION:
        found = payload.get("catalog_version")
        raise CatalogError(f"{path}: catalog version {found} is not {CATALOG_VERSION}")
    entries = payload.get("objects")
    if not isinstance(entries, list):
        raise CatalogError(f"{path}: 'objects' must be a list, got {type(entries).__name__}")
    if not isinstance(payload.get("meta", {}), dict):
        raise CatalogError(f"{path}: 'meta' must be a JSON object")
    records = [object_from_json(entry, set_dir, i) for i, entry in enumerate(entries)]
    seen: set[str] = set()
    for record in records:
        if record.object_id in seen:
            raise CatalogError(f"{path}: object {record.object_id} is listed twice")
        seen.add(record.object_id)
    for record in records:
        for name in record.file_names:
            if not record.path(name).is_file():
                raise CatalogError(f"object {record.object_id}: file {record.path(name)} is missing")
    return records


def load_meta(set_dir: str | Path) -> dict[str, Any]:
    """The ``meta`` mapping of a set's catalog ({} if the set has no catalog yet); checks the catalog."""
    set_dir = Path(set_dir)
    if not (set_dir / CATALOG_NAME).is_file():
        return {}
    load_catalog(set_dir)
    meta = json.loads((set_dir / CATALOG_NAME).read_text()).get("meta", {})
    return dict(meta)


def load_object(set_dir: str | Path, object_id: str) -> ObjectRecord:
    """One record of a set by id; an unknown id raises CatalogError listing a few known ones."""
    records = load_catalog(set_dir)
    for record in records:
        if record.object_id == object_id:
            return record
    known = ", ".join(r.object_id for r in records[:5])
    raise CatalogError(f"no object '{object_id}' in {set_dir} (it has {len(records)}: {known}, ...)")
