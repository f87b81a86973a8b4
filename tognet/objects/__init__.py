"""Tool objects: procedural (PG-Primitive, PG-Complex), realistic and user meshes, as MuJoCo assets."""

from typing import TYPE_CHECKING

from tognet.lazy_names import lazy_names

if TYPE_CHECKING:  # the names below, for type checkers; at run time they load on first use
    from tognet.objects.assemble import MeshError, assemble_object
    from tognet.objects.generate import GeneratorConfig, generate_object, generate_set, object_id, object_seed
    from tognet.objects.importer import ImportReport, import_meshes
    from tognet.objects.record import CatalogError, ObjectRecord, load_catalog, load_object, write_catalog

# name -> the module that defines it; loaded on first use (tognet.lazy_names).
_WHERE = {
    "MeshError": "tognet.objects.assemble",
    "assemble_object": "tognet.objects.assemble",
    "GeneratorConfig": "tognet.objects.generate",
    "generate_object": "tognet.objects.generate",
    "generate_set": "tognet.objects.generate",
    "object_id": "tognet.objects.generate",
    "object_seed": "tognet.objects.generate",
    "ImportReport": "tognet.objects.importer",
    "import_meshes": "tognet.objects.importer",
    "CatalogError": "tognet.objects.record",
    "ObjectRecord": "tognet.objects.record",
    "load_catalog": "tognet.objects.record",
    "load_object": "tognet.objects.record",
    "write_catalog": "tognet.objects.record",
}


__getattr__, __dir__ = lazy_names(__name__, _WHERE)


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
