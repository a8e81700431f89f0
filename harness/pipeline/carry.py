"""A model's files carried to the node that runs it: the MJCF and every file it names (meshes, textures,
height fields, skins, included and attached MJCF), packed on this machine and unpacked on a node.

A task that judges a user's model on a cluster gets a :class:`Carried` instead of a path: the node may not
see this machine's files. :func:`pack` reads the model and what it names; :meth:`Carried.here` gives its
path on the node that runs the task, the files unpacked there once per node (keyed by their digest, in a
folder of the system's temporary directory) and reused by every later task of the model. What the run reports
names the user's path, never the node's: the driver renames it (:func:`harness.pipeline.matrix._named_here`).

Which files a model names is read from its XML, as MuJoCo resolves them: a mesh's, skin's, texture's or
height field's ``file`` in the compiler's ``meshdir``/``texturedir``/``assetdir`` (or beside the model),
an ``<include>``'s or an attached ``<model>``'s beside the model, each read recursively. A name found in
more than one of those places is carried from each (a file too many costs bytes, one too few a failed
run). Files are carried with their place relative to the deepest folder holding them all; an absolute
name stays absolute (the node must have that file itself).
"""

from __future__ import annotations

import hashlib
import os
import shutil
import tempfile
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path, PurePosixPath

__all__ = ["Carried", "pack"]

ASSETS = {"mesh": ("meshdir",), "skin": ("meshdir",), "texture": ("texturedir",), "hfield": ("texturedir",)}
"""Elements whose ``file`` attributes (``file``, and a cube texture's ``fileright`` …) name an asset, and the
compiler attribute of the folder MuJoCo looks in (``assetdir`` standing for both)."""

MJCF = ("include", "model")
"""Elements whose ``file`` is another MJCF, read for the files it names in turn."""

LIMIT = 512 * 2**20
"""The most bytes one model may carry: a model folder that large is a mistake (a home folder named), not a robot."""


@dataclass(frozen=True)
class Carried:
    """A model's files: ``path`` the user's path to it (as given), ``entry`` its place among ``files``
    (place, bytes), ``digest`` the SHA-256 of them all."""

    path: str
    entry: str
    files: tuple[tuple[str, bytes], ...]
    digest: str

    @property
    def size(self) -> int:
        return sum(len(data) for _, data in self.files)

    def here(self) -> Path:
        """The model's file on this node: the files unpacked under the temporary directory (once per node;
        every later call reuses them)."""
        home = Path(tempfile.gettempdir()) / f"mjharness-carried-{os.getuid() if hasattr(os, 'getuid') else 0}"
        folder = home / self.digest[:32]
        if not (folder / self.entry).is_file():
            home.mkdir(parents=True, exist_ok=True)
            staging = Path(tempfile.mkdtemp(prefix=".unpacking-", dir=home))
            try:
                for place, data in self.files:
                    target = staging / _inside(place)
                    target.parent.mkdir(parents=True, exist_ok=True)
                    target.write_bytes(data)
                try:
                    staging.rename(folder)  # whole or not at all: a concurrent task's copy may be there first
                except OSError:
                    if not (folder / self.entry).is_file():
                        raise
            finally:
                shutil.rmtree(staging, ignore_errors=True)
        return folder / self.entry


def _inside(place: str) -> PurePosixPath:
    """A carried file's place, refused where it would leave the folder it is unpacked in."""
    relative = PurePosixPath(place)
    if relative.is_absolute() or ".." in relative.parts or not relative.parts:
        raise ValueError(f"a carried file's place {place!r} is not inside the model's folder")
    return relative


def files_of(path: Path) -> list[Path]:
    """The model at ``path`` and every file it names that exists (see the module's docstring), each once."""
    found: dict[Path, None] = {}
    _scan(path.resolve(), path.resolve().parent, {}, found)
    return list(found)


def _scan(path: Path, main: Path, dirs: dict[str, str], found: dict[Path, None]) -> None:
    if path in found or not path.is_file():
        return
    found[path] = None
    try:
        root = ET.parse(path).getroot()
    except (ET.ParseError, OSError):  # not XML: MuJoCo's parser says what is wrong, on the node as here
        return
    dirs = dict(dirs)
    for compiler in root.iter("compiler"):
        for name in ("assetdir", "meshdir", "texturedir"):
            if compiler.get(name) is not None:
                dirs[name] = compiler.get(name, "")
    for element in root.iter():
        names = [v for k, v in element.attrib.items() if k.startswith("file") and v]
        if element.tag in MJCF:
            for name in names:
                for candidate in (main / name, path.parent / name):
                    _scan(candidate.resolve(), main, dirs, found)
        elif element.tag in ASSETS:
            folders = [dirs.get(d, dirs.get("assetdir", "")) for d in ASSETS[element.tag]]
            for name in names:
                for candidate in {main / f / name for f in (*folders, "")}:
                    if candidate.is_file():
                        found.setdefault(candidate.resolve(), None)


def pack(path: Path | str) -> Carried:
    """The model at ``path`` with every file it names, to carry to another node. ValueError (one line) where
    it cannot be read or carries more than :data:`LIMIT` bytes."""
    given = str(path)
    model = Path(path)
    if not model.is_file():
        raise ValueError(f"{given!r} is no model file to carry to the cluster; accepted: an MJCF file")
    files = files_of(model)
    common = Path(os.path.commonpath([str(f.parent) for f in files]))
    size = sum(f.stat().st_size for f in files)
    if size > LIMIT:
        raise ValueError(f"{given!r} names {len(files)} files of {size / 2**20:.0f} MiB in all, more than the "
                         f"{LIMIT // 2**20} MiB a model may carry to a cluster's node; accepted: a model of "
                         "fewer or smaller files, or --executor local")
    digest = hashlib.sha256()
    carried = []
    for f in sorted(files):
        place = f.relative_to(common).as_posix()
        data = f.read_bytes()
        for part in (place.encode(), data):
            digest.update(len(part).to_bytes(8, "little"))
            digest.update(part)
        carried.append((place, data))
    return Carried(given, model.resolve().relative_to(common).as_posix(), tuple(carried), digest.hexdigest())
