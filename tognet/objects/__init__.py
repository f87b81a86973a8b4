"""Tool objects: procedural (PG-Primitive, PG-Complex), realistic and user meshes, as MuJoCo assets."""

from tognet.objects.assemble import MeshError, assemble_object
from tognet.objects.generate import GeneratorConfig, generate_object, generate_set, object_id, object_seed
from tognet.objects.importer import ImportReport, import_meshes
from tognet.objects.record import CatalogError, ObjectRecord, load_catalog, load_object, write_catalog

__all__ = [
    "CatalogError",
    "GeneratorConfig",
    "ImportReport",
    "MeshError",
    "ObjectRecord",
    "assemble_object",
    "generate_object",
    "generate_set",
    "import_meshes",
    "load_catalog",
    "load_object",
    "object_id",
    "object_seed",
    "write_catalog",
]
