"""Jobs that need no shared folder: the files a job reads travel with it through Ray, by content.

A job names files on the coordinator's disk: its object's meshes and MJCF (``ObjectRecord.folder``) and
its checkpoints (every ``*_model`` field). On a cluster whose nodes do not mount that disk at the same
path (``ray up`` on cloud machines, KubeRay pods) those paths do not resolve. So, under Ray:

- the coordinator (:class:`FileShipper`) hashes each file a job names (once per file, remembered by
  path, size and modification time), puts each distinct content once into Ray's object store and sends
  the job with a :data:`Manifest` of (name, sha256, size, reference) per field;
- on the node, :func:`materialise` writes each file once into a local cache keyed by content
  (``$TOGNET_CACHE_DIR``, by default ``~/.cache/tognet/files``: ``<digest of the bundle>/<name>``),
  checking every byte against its sha256, and the job runs on a copy of itself that points there.

Records still come back to the coordinator, which alone writes the run folder. Local worker processes
share the coordinator's disk and use none of this.
"""

from __future__ import annotations

import dataclasses
import hashlib
import os
from collections.abc import Callable
from pathlib import Path
from typing import Any

from tognet.io import atomic_write_bytes, sha256_file
from tognet.jobs.output import JobOutput
from tognet.objects.record import ObjectRecord

#: The environment variable that moves a node's file cache (default ``~/.cache/tognet/files``).
CACHE_ENV = "TOGNET_CACHE_DIR"


@dataclasses.dataclass(frozen=True)
class ShippedFile:
    """One file a job reads, as it travels: its name in the bundle, its content's digest and size, and
    the Ray object that holds its bytes."""

    name: str
    sha256: str
    size: int
    ref: Any


#: Per job field that names files (``obj``, ``grasp_model``, ...): the files it names.
Manifest = dict[str, tuple[ShippedFile, ...]]


class FileShipError(RuntimeError):
    """A file a job needs could not be read on the coordinator or arrived damaged on a node."""


def cache_dir() -> Path:
    """This node's content-keyed file cache."""
    return Path(os.environ.get(CACHE_ENV) or Path.home() / ".cache" / "tognet" / "files")


def job_files(job: Any) -> dict[str, list[tuple[str, Path]]]:
    """Per field of ``job`` that names files: (name in the bundle, path on this machine) of each.
    An object record names its folder's files; a ``*_model`` field names one checkpoint."""
    named: dict[str, list[tuple[str, Path]]] = {}
    for f in dataclasses.fields(job):
        value = getattr(job, f.name)
        if isinstance(value, ObjectRecord):
            named[f.name] = [(name, value.path(name)) for name in value.file_names]
        elif f.name.endswith("_model") and isinstance(value, str) and value:
            named[f.name] = [(Path(value).name, Path(value))]
    return named


class FileShipper:
    """The coordinator's side: each distinct file content put into the object store once per run."""

    def __init__(self, put: Callable[[bytes], Any]) -> None:
        self._put = put
        self._digests: dict[tuple[str, int, int], str] = {}
        self._refs: dict[str, Any] = {}

    def manifest(self, job: Any) -> Manifest:
        """The job's files as they travel; :class:`FileShipError` names a file that cannot be read."""
        return {name: tuple(self._ship(n, p) for n, p in files) for name, files in job_files(job).items()}

    def _ship(self, name: str, path: Path) -> ShippedFile:
        try:
            st = path.stat()
            key = (str(path.resolve()), st.st_size, st.st_mtime_ns)
            sha = self._digests.get(key)
            if sha is None or sha not in self._refs:
                data = path.read_bytes()
                sha = hashlib.sha256(data).hexdigest()
                self._digests[key] = sha
                if sha not in self._refs:
                    self._refs[sha] = self._put(data)
        except OSError as exc:
            raise FileShipError(f"cannot read {path} to send it to the cluster ({exc.strerror or exc})"
                                ) from exc
        return ShippedFile(name, sha, st.st_size, self._refs[sha])

    def release(self) -> None:
        """Drop the references (the object store frees the bytes once no task holds them)."""
        self._refs.clear()


_VERIFIED: dict[tuple[str, int, int], str] = {}  # files this process has hashed: path, size, mtime


def _holds(path: Path, f: ShippedFile) -> bool:
    """Whether ``path`` already holds ``f``'s content (hashed once per process and file version)."""
    try:
        st = path.stat()
    except OSError:
        return False
    if st.st_size != f.size:
        return False
    key = (str(path), st.st_size, st.st_mtime_ns)
    if key not in _VERIFIED:
        _VERIFIED[key] = sha256_file(path)
    return _VERIFIED[key] == f.sha256


def bundle_folder(files: tuple[ShippedFile, ...], root: Path | None = None) -> Path:
    """Where a bundle lives in the cache: named by the digest of its names and contents, so two objects
    or checkpoints never share a folder unless they are the same bytes under the same names."""
    listing = "\n".join(f"{f.name}:{f.sha256}" for f in sorted(files, key=lambda f: f.name))
    return (root or cache_dir()) / hashlib.sha256(listing.encode()).hexdigest()[:32]


def materialise(manifest: Manifest, get: Callable[[Any], bytes]) -> dict[str, Path]:
    """Each bundle's folder in this node's cache, fetching (``get``) only what is not there whole."""
    folders: dict[str, Path] = {}
    for field, files in manifest.items():
        folder = bundle_folder(files)
        for f in files:
            path = folder / f.name
            if _holds(path, f):
                continue
            data = get(f.ref)
            if hashlib.sha256(data).hexdigest() != f.sha256:
                raise FileShipError(f"{f.name} arrived damaged on this node (sha256 differs from the "
                                    "coordinator's file)")
            atomic_write_bytes(path, data)
        folders[field] = folder
    return folders


def relocate(job: Any, folders: dict[str, Path]) -> Any:
    """A copy of ``job`` whose files are read from ``folders`` (per field, as :func:`materialise` gives)."""
    changes: dict[str, Any] = {}
    for field, folder in folders.items():
        value = getattr(job, field)
        if isinstance(value, ObjectRecord):
            changes[field] = dataclasses.replace(value, folder=str(folder))
        else:
            changes[field] = str(folder / Path(value).name)
    return dataclasses.replace(job, **changes)


def run_shipped(fn: Callable[[Any], JobOutput], job: Any, manifest: Manifest) -> JobOutput:
    """On a Ray worker: bring the job's files into this node's cache, then run ``fn`` on the job as it
    reads them there."""
    import ray

    try:
        folders = materialise(manifest, ray.get)
    except (OSError, FileShipError) as exc:
        error = f"{job.obj.object_id}: its files could not be set up on node {ray.util.get_node_ip_address()}"
        return JobOutput(job.index, {}, {}, error=f"{error} ({exc})")
    return fn(relocate(job, folders))


__all__ = ["CACHE_ENV", "FileShipError", "FileShipper", "Manifest", "ShippedFile", "bundle_folder",
           "cache_dir", "job_files", "materialise", "relocate", "run_shipped"]
