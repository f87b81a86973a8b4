"""Tool objects: procedural (PG-Primitive, PG-Complex), realistic, and user meshes, written as MuJoCo assets."""

from tognet.objects.assemble import MeshError, assemble_object
from tognet.objects.record import CatalogError, ObjectRecord, load_catalog, load_object, write_catalog

__all__ = [
    "CatalogError",
    "MeshError",
    "ObjectRecord",
    "assemble_object",
    "load_catalog",
    "load_object",
    "write_catalog",
]
