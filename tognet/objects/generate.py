"""Deterministic object sets: (kind, split, index) -> the same object, byte for byte, on any machine.

- ``object_id(kind, split, index) = f"{kind}-{split}-{index:06d}"``.
- The generator's random stream is seeded from (kind, split, index) through SHA-256 (never Python's
  ``hash()``, which is salted per process), so train and test objects come from different streams and
  their ids differ by construction.
- ``generate_set`` writes the objects, ``catalog.json`` and ``generator_config.json`` (the
  :class:`GeneratorConfig` used) into one folder. Objects already in the folder's catalog are kept:
  generating indices that exist again rewrites them identically.
- ``GENERATOR_VERSION`` (saved in the catalog's meta) changes whenever the same (kind, split, index)
  and config would give different files; adding objects to a set made by another version is refused.
- Generator profiles (:data:`PROFILES`, files in ``tognet/objects/profiles``) are GeneratorConfigs found
  by name (:func:`load_generator_config`, ``objects generate --config NAME``): ``wide`` widens the
  training objects towards real tools (flat blades and handles 3-15 mm high, thin shafts 3-12 mm, tall
  heads to 10 cm, lengths from 8 cm, friction from 0.35, metal to 8000 kg/m^3, masses 20 g-1.5 kg). It
  is opt-in: the default config, and so the README's test sets, stay byte for byte the same.
- The realistic set is a fixed list of models (``tognet.objects.realistic``); it is a test set only
  (the paper never trains on it), index i is model i, and asking for more objects than there are
  models is an error that names the limit (the models have real-world sizes, so they are not rescaled).
"""

from __future__ import annotations

import hashlib
import multiprocessing
from collections.abc import Iterable
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import trimesh
from tqdm import tqdm

from tognet.config import Config, ConfigError, doc
from tognet.objects.assemble import MeshError, assemble_object, exclusive_solids
from tognet.objects.complex import ComplexConfig, make_complex
from tognet.objects.compose import part_densities
from tognet.objects.primitive import PrimitiveConfig, make_primitive
from tognet.objects.record import CATALOG_NAME, SPLITS, ObjectRecord, load_catalog, load_meta, write_catalog

GENERATED_KINDS = ("primitive", "complex", "realistic")
CONFIG_NAME = "generator_config.json"
SEED_NAMESPACE = "tognet/objects/v1"
MAX_ATTEMPTS = 8
#: 1: first release; 2: density drawn from the feasible interval (no mass clamp);
#: 3: PG-Complex parts get a flat bottom face; 4: so do PG-Primitive polytopes;
#: 5: one density per part (light handle, sometimes metal head/arm), mass properties per part.
GENERATOR_VERSION = 5


@dataclass(frozen=True)
class GeneratorConfig(Config):
    """Everything that decides what the procedural generators draw (saved next to each catalog)."""

    primitive: PrimitiveConfig = doc(factory=PrimitiveConfig, text="PG-Primitive settings.")
    complex: ComplexConfig = doc(factory=ComplexConfig, text="PG-Complex settings.")


#: The shipped generator profiles: ``wide`` (tognet/objects/profiles/wide.json; see the module docstring).
PROFILES = ("wide",)
#: Where the profiles' files are (shipped inside the package).
PROFILES_DIR = Path(__file__).resolve().parent / "profiles"


def load_generator_config(name_or_path: str | Path) -> GeneratorConfig:
    """A generator profile by name (one of :data:`PROFILES`, or ``default``) or a GeneratorConfig file."""
    text = str(name_or_path)
    if text == "default":
        return GeneratorConfig()
    if text in PROFILES:
        return GeneratorConfig.load(PROFILES_DIR / f"{text}.json")
    path = Path(text)
    if not path.exists() and path.suffix.lower() != ".json" and "/" not in text:
        raise ConfigError(f"unknown generator profile {text!r}: use default, {', '.join(PROFILES)} or a "
                          "GeneratorConfig JSON file's path")
    return GeneratorConfig.load(path)


def object_id(kind: str, split: str, index: int) -> str:
    """The id of object ``index`` of a kind and split, e.g. ``primitive-train-000042``."""
    return f"{kind}-{split}-{index:06d}"


def object_seed(kind: str, split: str, index: int) -> int:
    """A 63-bit seed from (kind, split, index), stable across machines and Python processes."""
    digest = hashlib.sha256(f"{SEED_NAMESPACE}/{kind}/{split}/{index}".encode()).digest()
    return int.from_bytes(digest[:8], "little") >> 1


def _check(kind: str, split: str, index: int) -> None:
    if kind not in GENERATED_KINDS:
        raise ValueError(f"unknown object kind {kind!r}; expected one of {', '.join(GENERATED_KINDS)}")
    if split not in SPLITS:
        raise ValueError(f"unknown split {split!r}; expected one of {', '.join(SPLITS)}")
    if index < 0:
        raise ValueError(f"object index must be >= 0, got {index}")


def _realistic_module() -> Any:
    """The realistic set's module (loaded on first use: it builds meshes with trimesh)."""
    import tognet.objects.realistic as realistic

    return realistic


def realistic_count() -> int:
    """How many realistic models exist."""
    return len(_realistic_module().REALISTIC_NAMES)


def _generate_realistic(split: str, index: int, set_dir: Path) -> ObjectRecord:
    if split != "test":
        raise ValueError("the realistic set is a test set only: use --split test")
    module = _realistic_module()
    limit = len(module.REALISTIC_NAMES)
    if index >= limit:
        raise ValueError(f"realistic index {index} out of range: there are {limit} realistic models")
    model = module.make_realistic(index)
    visual = model.visual.copy()
    lo, hi = visual.bounds
    shift = -(lo + hi) / 2
    visual.apply_translation(shift)
    pieces = [p.copy() for p in model.pieces]
    for piece in pieces:
        piece.apply_translation(shift)
    parts = []
    for _material, solid, rho in model.parts:
        moved = solid.copy()
        moved.apply_translation(shift)
        parts.append((moved, rho))
    return assemble_object(
        set_dir,
        object_id=object_id("realistic", split, index),
        kind="realistic",
        split=split,
        shape_rule="none",
        part_types=[model.category],
        visual=visual,
        collision_pieces=pieces,
        parts=parts,
        part_names=[material for material, _, _ in model.parts],
        friction=model.friction,
        extra={"name": model.name, "category": model.category, "tool_like": bool(model.tool_like)},
    )


def generate_object(
    kind: str, split: str, index: int, set_dir: Path, config: GeneratorConfig | None = None
) -> ObjectRecord:
    """Generate object ``index`` of ``kind`` (primitive|complex|realistic) and ``split`` (train|test).

    Writes ``set_dir/<object_id>/`` (collision pieces, visual, MJCF) and returns the record; the
    catalog is written by :func:`generate_set`.
    """
    _check(kind, split, index)
    set_dir = Path(set_dir)
    if kind == "realistic":
        return _generate_realistic(split, index, set_dir)
    config = config or GeneratorConfig()
    seed = object_seed(kind, split, index)
    last_error: Exception | None = None
    for attempt in range(MAX_ATTEMPTS):
        rng = np.random.default_rng(np.random.SeedSequence([seed, attempt]))
        try:
            if kind == "primitive":
                visual, pieces, rule, types, info = make_primitive(rng, config.primitive)
                ranges = config.primitive.ranges
            else:
                visual, pieces, rule, types, info = make_complex(rng, config.complex)
                ranges = config.complex.ranges
        except MeshError as exc:
            last_error = exc
            continue
        part_a, part_b = pieces
        own_b, own_a = (0.0 if s is None else float(s.volume) for s in exclusive_solids([part_b, part_a]))
        rho_a, rho_b, (class_a, class_b) = part_densities(rng, ranges, rule, own_a, own_b)
        friction = float(rng.uniform(*ranges.friction))
        return assemble_object(
            set_dir,
            object_id=object_id(kind, split, index),
            kind=kind,
            split=split,
            shape_rule=rule,
            part_types=types,
            visual=visual,
            collision_pieces=pieces,
            parts=[(part_b, rho_b), (part_a, rho_a)],
            part_names=["B", "A"],
            friction=friction,
            extra={"seed": seed, "attempt": attempt, **info, "part_materials": {"A": class_a, "B": class_b}},
        )
    name = object_id(kind, split, index)
    raise MeshError(f"{name}: no valid object in {MAX_ATTEMPTS} attempts ({last_error})")


def _existing(out: Path) -> list[ObjectRecord]:
    return load_catalog(out) if (out / CATALOG_NAME).is_file() else []


def generate_set(
    kind: str,
    split: str,
    count: int,
    out: Path,
    start: int = 0,
    progress: bool = False,
    config: GeneratorConfig | None = None,
    workers: int = 1,
) -> list[ObjectRecord]:
    """Generate objects ``start .. start+count-1`` into ``out`` and (re)write its catalog.

    Objects already listed in ``out/catalog.json`` stay in it; a folder whose saved generator config
    differs from ``config`` is refused (its objects would be described wrongly). If an object fails,
    the catalog still lists every object written before the error. ``workers`` > 1 generates in that
    many processes (the files do not depend on it). Returns the new records in index order.
    For ``kind="realistic"`` the split must be ``test`` and ``start + count`` may not exceed the number
    of realistic models.
    """
    _check(kind, split, start)
    if count < 1:
        raise ValueError(f"count must be >= 1, got {count}")
    if kind == "realistic" and split != "test":
        raise ValueError("the realistic set is a test set only: use --split test")
    if kind == "realistic" and start + count > realistic_count():
        raise ValueError(
            f"asked for realistic objects {start}..{start + count - 1} but there are only "
            f"{realistic_count()} realistic models (use --count {max(realistic_count() - start, 0)} or less)"
        )
    if workers < 1:
        raise ValueError(f"workers must be >= 1, got {workers}")
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise ValueError(f"--out {out} is a file, not a folder")
    config = config or GeneratorConfig()
    if (out / CONFIG_NAME).is_file() and GeneratorConfig.load(out / CONFIG_NAME) != config:
        raise ValueError(
            f"{out} holds objects made with a different generator config ({out / CONFIG_NAME}); "
            "use another folder"
        )
    meta = load_meta(out)
    if (out / CATALOG_NAME).is_file() and (out / CONFIG_NAME).is_file():
        version = meta.get("generator_version", 1)
        if version != GENERATOR_VERSION:
            raise ValueError(
                f"{out} holds objects made by generator version {version}, this is version "
                f"{GENERATOR_VERSION} (same ids would differ); use another folder"
            )
    existing = {r.object_id: r for r in _existing(out)}
    records: list[ObjectRecord] = []
    indices = range(start, start + count)
    bar = tqdm(total=count, desc=f"{kind}/{split}", unit="obj", disable=not progress)
    try:
        if workers == 1:
            results: Iterable[ObjectRecord] = (
                generate_object(kind, split, i, out, config=config) for i in indices
            )
            _collect(results, records, existing, bar)
        else:
            # spawned, not forked: a parent that has rendered (EGL) or run torch threads hangs forked children
            # (seen: `tognet demo` after its GIF stalled generating the evaluation's test objects)
            spawn = multiprocessing.get_context("spawn")
            with ProcessPoolExecutor(max_workers=workers, mp_context=spawn) as pool:
                jobs = pool.map(_generate_job, [(kind, split, i, str(out), config) for i in indices])
                _collect(jobs, records, existing, bar)
    finally:
        bar.close()
        if records:
            config.save(out / CONFIG_NAME)
            kinds = sorted({r.kind for r in existing.values()})
            meta.update(
                {"kinds": kinds, "generator_config": CONFIG_NAME, "generator_version": GENERATOR_VERSION}
            )
            write_catalog(out, list(existing.values()), meta=meta)
    return records


def _generate_job(args: tuple[str, str, int, str, GeneratorConfig]) -> ObjectRecord:
    kind, split, index, out, config = args
    return generate_object(kind, split, index, Path(out), config=config)


def _collect(
    results: Iterable[ObjectRecord], records: list[ObjectRecord], existing: dict[str, ObjectRecord], bar: tqdm
) -> None:
    for record in results:
        records.append(record)
        existing[record.object_id] = record
        bar.update(1)


def load_mesh(path: Path) -> trimesh.Trimesh:
    """Load one object mesh file written by this package (OBJ, no processing beyond merging)."""
    return trimesh.load(path, force="mesh", process=False)
