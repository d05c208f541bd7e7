"""A disk cache for meshes and precomputed data, keyed by the parameters that define them.

Entries are files named by a hash of (kind, key, the versions of this package
and of the libraries that write them: a mesh file that netgen 6.2.2608 wrote
does not load in netgen 6.2.2604); a new
entry is written to a temporary file in the same folder and moved into place
with os.replace, which is atomic, so processes sharing the cache never read a
half-written entry (at worst two of them build the same entry once each).
Location: the environment variable FEM_PENDULUM_CACHE, else
$XDG_CACHE_HOME/fem_pendulum_fmu, else ~/.cache/fem_pendulum_fmu. Set
FEM_PENDULUM_CACHE=off to disable it.

Three ways in: load_or_build (bytes, e.g. an .npz), load_or_build_json, and
cached_file (a file a callback writes, e.g. a netgen .vol mesh).
"""

from __future__ import annotations

import hashlib
import json
import logging
import os
import tempfile
from collections.abc import Callable
from functools import lru_cache
from importlib import metadata
from pathlib import Path
from typing import Any

from ..version import __version__

LOG = logging.getLogger("fem_pendulum_fmu")
ENV = "FEM_PENDULUM_CACHE"


def cache_dir() -> Path | None:
    """The cache folder, or None when caching is off."""
    setting = os.environ.get(ENV)
    if setting and setting.lower() in ("off", "0", "none", "false"):
        return None
    if setting:
        return Path(setting)
    base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base) / "fem_pendulum_fmu"


@lru_cache(maxsize=1)
def writer_versions() -> dict[str, str]:
    """This package's version and those of the libraries whose files and numbers the cache holds."""
    versions = {"fem_pendulum_fmu": __version__}
    for name in ("netgen-mesher", "ngsolve", "numpy", "scipy"):
        try:
            versions[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            versions[name] = "absent"
    return versions


def entry_name(kind: str, key: dict[str, Any], suffix: str) -> str:
    text = json.dumps({"kind": kind, "key": key, "version": writer_versions()}, sort_keys=True, default=repr)
    return f"{kind}-{hashlib.sha256(text.encode()).hexdigest()[:24]}{suffix}"


def write_atomically(path: Path, write: Callable[[Path], None]) -> Path:
    """`write(tmp)` to a temporary file beside `path`, renamed to `path` when it is complete: a
    reader (another process) sees the whole file or none (its folder is made if missing)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.stem}_", suffix=path.suffix, dir=path.parent)
    os.close(fd)
    try:
        write(Path(tmp))
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)
    return path


def cached_file(kind: str, key: dict[str, Any], suffix: str, write: Callable[[Path], None]) -> Path | None:
    """Path of the entry for (kind, key), written by `write(path)` if absent; None if caching is off
    or the folder cannot be written (the caller then builds without the cache)."""
    folder = cache_dir()
    if folder is None:
        return None
    path = folder / entry_name(kind, key, suffix)
    if path.exists():
        return path
    try:
        write_atomically(path, write)
    except OSError as exc:
        LOG.warning("cache %s not usable (%s); building without it", folder, exc)
        return None
    return path


def load_or_build(kind: str, key: dict[str, Any], build: Callable[[], bytes]) -> bytes:
    """Bytes (e.g. an .npz) from the cache, built and stored on a miss; built without storing
    when caching is off or the folder cannot be written."""
    built: list[bytes] = []

    def write(path: Path) -> None:
        built.append(bytes(build()))
        path.write_bytes(built[0])

    path = cached_file(kind, key, ".bin", write)
    if built:
        return built[0]
    if path is None:
        return bytes(build())
    return path.read_bytes()


def load_or_build_json(kind: str, key: dict[str, Any], build: Callable[[], Any]) -> Any:
    """A JSON-able value from the cache, built and stored on a miss."""
    value: list[Any] = []

    def write(path: Path) -> None:
        value.append(build())
        path.write_text(json.dumps(value[0]))

    path = cached_file(kind, key, ".json", write)
    if value:
        return value[0]
    if path is None:
        return build()
    return json.loads(path.read_text())
