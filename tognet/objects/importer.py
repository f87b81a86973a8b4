"""Your own meshes: a folder of OBJ/STL/PLY files -> simulated objects (kind ``imported``).

Each file goes through the same pipeline as the generated objects: scale (``scale``: file units to
metres), checks, convex decomposition (CoACD, capped hull vertices), mass properties from a density,
friction, MJCF. What is checked, in order, and the error each failure gives (naming the file):

1. readable by trimesh (``unreadable``), has triangles (``empty``);
2. repaired: duplicate vertices merged, degenerate/duplicate faces dropped, normals made consistent,
   small holes (triangles/quads) filled;
3. not flat and of positive volume (``degenerate``);
4. longest side within [min_size, max_size] after scaling (``absurd size``);
5. watertight after the repair (``not watertight``): mass properties need a closed surface, so open
   meshes are refused rather than guessed at.

A file that fails is listed in ``ImportReport.errors`` and the others are still imported. The object
id is ``imported-<file stem>`` (lower case, other characters as ``_``). Objects already in the output
folder stay: a file whose id is already there is skipped (``ImportReport.kept``) when it is the same file
imported with the same settings (its sha256 is recorded), and refused (an error naming ``--replace``) when
it changed; with ``replace=True`` it replaces that object, only after the new one has been written
completely.

Before trimesh sees a file, its format is checked from its bytes (a binary STL's size must match the
triangle count in its header, an ASCII STL and an OBJ must be text, a PLY must start with ``ply``):
random or truncated files are named as such instead of failing inside a reader (which, given random
bytes, looks for a text-encoding detector, a module tognet does not install).
"""

from __future__ import annotations

import dataclasses
import hashlib
import re
import shutil
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import trimesh
from tqdm import tqdm

from tognet.errors import TognetError
from tognet.objects.assemble import assemble_object
from tognet.objects.decompose import DecomposeConfig, decompose
from tognet.objects.record import CATALOG_NAME, ObjectRecord, load_catalog, load_meta, write_catalog

MESH_SUFFIXES = (".obj", ".stl", ".ply")
MIN_SIZE = 0.01
MAX_SIZE = 1.5
DEFAULT_DENSITY = 1000.0
DEFAULT_FRICTION = 0.8


class ImportMeshError(TognetError):
    """One file cannot become an object; the message names the file and the reason."""


@dataclass
class ImportReport:
    """What ``import_meshes`` did: the objects written and the files refused (path, reason)."""

    records: list[ObjectRecord] = field(default_factory=list)
    errors: list[tuple[Path, str]] = field(default_factory=list)
    kept: list[tuple[Path, str]] = field(default_factory=list)
    catalog: Path | None = None


def _slug(stem: str) -> str:
    return re.sub(r"[^a-z0-9_-]+", "_", stem.lower()).strip("_") or "mesh"


def _is_text(data: bytes) -> bool:
    if b"\x00" in data[:1 << 16]:
        return False
    try:
        data.decode("utf-8")
    except UnicodeDecodeError:
        return False
    return True


def check_mesh_bytes(path: Path, data: bytes) -> None:
    """ImportMeshError when ``data`` cannot be a mesh file of ``path``'s type (see the module docstring)."""
    suffix = path.suffix.lower()
    if not data:
        raise ImportMeshError(f"{path}: empty file")
    if suffix == ".stl":
        count = int.from_bytes(data[80:84], "little") if len(data) >= 84 else None
        if count is not None and len(data) == 84 + 50 * count:
            return  # binary STL
        if data[:5].lower() == b"solid" and _is_text(data):
            return  # ASCII STL
        expected = 84 + 50 * count if count is not None else 0
        # A plausible triangle count (not the random number a damaged header gives) and too few bytes.
        if count and len(data) < expected <= max(20 * len(data), 1 << 20) and not _is_text(data):
            raise ImportMeshError(f"{path}: truncated binary STL: its header announces {count} triangles "
                                  f"({expected} bytes), the file has {len(data)} bytes")
        raise ImportMeshError(f"{path}: not an STL file (neither a binary STL of 84 + 50 bytes per triangle "
                              "nor ASCII text starting with 'solid'): damaged or truncated?")
    if suffix == ".obj" and not _is_text(data):
        raise ImportMeshError(f"{path}: not an OBJ file (OBJ is text; this holds binary data): damaged?")
    if suffix == ".ply" and not data.startswith(b"ply"):
        raise ImportMeshError(f"{path}: not a PLY file (it does not start with 'ply'): damaged?")


def load_checked(
    path: Path, scale: float = 1.0, min_size: float = MIN_SIZE, max_size: float = MAX_SIZE
) -> trimesh.Trimesh:
    """Load, scale, repair and check one mesh file; raise ImportMeshError naming the file on failure."""
    check_mesh_bytes(path, path.read_bytes())
    try:
        loaded = trimesh.load(path, force="mesh", process=False)
    except ImportError:  # a reader wanting an optional module: the file is not what its name says
        raise ImportMeshError(f"{path}: unreadable, damaged or truncated?") from None
    except Exception as exc:  # trimesh raises many kinds of errors on broken files
        raise ImportMeshError(
            f"{path}: unreadable, damaged or truncated? ({type(exc).__name__}: {str(exc).strip()})"
        ) from None
    if not isinstance(loaded, trimesh.Trimesh) or len(loaded.faces) == 0 or len(loaded.vertices) == 0:
        raise ImportMeshError(f"{path}: empty (no triangles)")
    mesh = trimesh.Trimesh(np.asarray(loaded.vertices, dtype=np.float64) * scale, loaded.faces, process=True)
    if not np.all(np.isfinite(mesh.vertices)):
        raise ImportMeshError(f"{path}: vertices are not finite numbers")
    mesh.update_faces(mesh.nondegenerate_faces())
    mesh.update_faces(mesh.unique_faces())
    mesh.remove_unreferenced_vertices()
    if len(mesh.faces) == 0:
        raise ImportMeshError(f"{path}: degenerate (every triangle has zero area)")
    trimesh.repair.fix_normals(mesh)
    trimesh.repair.fill_holes(mesh)
    extents = np.asarray(mesh.extents)
    longest = float(extents.max())
    if float(extents.min()) <= 1e-6 * max(longest, 1e-12):
        raise ImportMeshError(f"{path}: degenerate (flat: extents {np.round(extents, 6).tolist()} m)")
    if not min_size <= longest <= max_size:
        hint = "--scale 0.001 reads millimetres" if longest > max_size else "set --scale to metres per unit"
        raise ImportMeshError(
            f"{path}: absurd size: longest side {longest:.4g} m after scale {scale:g} "
            f"(allowed {min_size:g}..{max_size:g} m; wrong units? {hint})"
        )
    if not mesh.is_watertight:
        open_edges = len(trimesh.grouping.group_rows(mesh.edges_sorted, require_count=1))
        raise ImportMeshError(
            f"{path}: not watertight ({open_edges} open edges after merging vertices and filling small "
            "holes); close the surface in a mesh editor"
        )
    if not mesh.volume > 1e-9:
        raise ImportMeshError(f"{path}: degenerate (volume {mesh.volume:.3g} m^3)")
    return mesh


def import_meshes(
    src_dir: Path,
    out: Path,
    scale: float = 1.0,
    density: float = DEFAULT_DENSITY,
    friction: float = DEFAULT_FRICTION,
    split: str = "test",
    decompose_config: DecomposeConfig | None = None,
    progress: bool = False,
    replace: bool = False,
) -> ImportReport:
    """Import one OBJ/STL/PLY file, or every one of the folder ``src_dir`` (not recursive), into the object
    set ``out``. An object already in ``out`` is kept unless ``replace`` (see the module docstring).

    Returns an :class:`ImportReport`; raises only if ``src_dir`` is missing, is a file of another type or
    a folder without mesh files, or if the parameters are invalid.
    """
    src_dir, out = Path(src_dir), Path(out)
    files = _mesh_files(src_dir)
    if not scale > 0 or not density > 0 or not friction > 0:
        raise ValueError(f"scale, density and friction must be positive, got {scale}, {density}, {friction}")
    config = decompose_config or DecomposeConfig()
    if out.exists() and not out.is_dir():
        raise ValueError(f"--out {out} is a file, not a folder")
    existing = {r.object_id: r for r in load_catalog(out)} if (out / CATALOG_NAME).is_file() else {}
    meta = load_meta(out)
    report = ImportReport()
    staging = out / ".importing"
    seen: dict[str, Path] = {}
    for path in tqdm(files, desc="import", unit="file", disable=not progress):
        oid = f"imported-{_slug(path.stem)}"
        if oid in seen:
            report.errors.append((path, f"{path}: same object id {oid} as {seen[oid].name}; rename one"))
            continue
        seen[oid] = path
        sha = hashlib.sha256(path.read_bytes()).hexdigest()
        settings = {"sha256": sha, "scale": scale, "density": density, "friction": friction}
        old = existing.get(oid)
        if old is not None and not replace:
            _keep_existing(report, path, oid, old, settings, out)
            continue
        try:
            record = _build(path, oid, staging, split, config, settings)
        except ImportMeshError as exc:
            report.errors.append((path, str(exc)))
            continue
        except TognetError as exc:
            report.errors.append((path, f"{path}: {exc}"))
            continue
        except Exception as exc:  # a library failing on one odd file must not stop the others
            report.errors.append((path, f"{path}: could not be processed ({type(exc).__name__}: {exc})"))
            continue
        final = _move_into(out, staging, oid)
        record = dataclasses.replace(record, folder=str(final.resolve()))
        existing[oid] = record
        report.records.append(record)
    shutil.rmtree(staging, ignore_errors=True)
    if report.records:
        meta["kinds"] = sorted({r.kind for r in existing.values()})
        report.catalog = write_catalog(out, list(existing.values()), meta=meta)
    return report


def _mesh_files(src: Path) -> list[Path]:
    """The mesh file ``src``, or the mesh files of the folder ``src`` (sorted, not recursive)."""
    kinds = "/".join(s[1:].upper() for s in MESH_SUFFIXES)
    if src.is_file():
        if src.suffix.lower() not in MESH_SUFFIXES:
            raise ValueError(f"{src}: not a mesh file ({kinds}, by its extension)")
        return [src]
    if not src.is_dir():
        raise FileNotFoundError(f"mesh file or folder not found: {src}")
    files = sorted(p for p in src.iterdir() if p.is_file() and p.suffix.lower() in MESH_SUFFIXES)
    if not files:
        raise FileNotFoundError(f"no {kinds} files in {src}")
    return files


def _keep_existing(report: ImportReport, path: Path, oid: str, old: ObjectRecord, settings: dict[str, Any],
                   out: Path) -> None:
    """An object already imported is kept: said so when it came from this file with these settings, an
    error naming what changed otherwise."""
    before = {k: old.extra.get(k) for k in settings}
    if before == settings:
        report.kept.append((path, f"{oid}: already in {out} from this file with these settings"))
        return
    what = "the file changed" if before["sha256"] not in (None, settings["sha256"]) else \
        "the settings differ" if before["sha256"] == settings["sha256"] else "it may differ"
    report.errors.append((path, f"{path}: {oid} is already in {out} and {what}; the object there is kept "
                                "(pass --replace to overwrite it)"))


def _build(path: Path, oid: str, staging: Path, split: str, config: DecomposeConfig,
           settings: dict[str, Any]) -> ObjectRecord:
    """The object of one mesh file, built in ``staging``: centred, convex-decomposed, assembled."""
    mesh = load_checked(path, settings["scale"])
    lo, hi = mesh.bounds
    shift = -(lo + hi) / 2
    mesh.apply_translation(shift)
    pieces = decompose(mesh, config, seed=0)
    if not pieces:
        raise ImportMeshError(f"{path}: convex decomposition gave no pieces")
    return assemble_object(
        staging,
        object_id=oid,
        kind="imported",
        split=split,
        shape_rule="none",
        part_types=["mesh"],
        visual=mesh,
        collision_pieces=pieces,
        density=settings["density"],
        friction=settings["friction"],
        extra={"source": path.name, "scale": settings["scale"],
               "offset": [round(float(v), 9) for v in shift], "sha256": settings["sha256"],
               "density": settings["density"], "friction": settings["friction"]},
    )


def _move_into(out: Path, staging: Path, oid: str) -> Path:
    """Move the built object from ``staging`` into ``out``, over an older one of the same id."""
    final = out / oid
    if final.exists():
        old = out / f".replaced-{oid}"
        shutil.rmtree(old, ignore_errors=True)
        final.rename(old)
        (staging / oid).rename(final)
        shutil.rmtree(old)
    else:
        out.mkdir(parents=True, exist_ok=True)
        (staging / oid).rename(final)
    return final
