"""Releasing and downloading splits: ``pack`` writes what a mirror hosts, ``download`` fetches it.

A release directory holds, per part, the shard files and ``manifest.json`` under
``<split>/<part>/``, and ``<split>/registry.txt``: one line ``<part>/<file> <sha256> <bytes>``
per file (pooch's registry format plus the size). Any static web server or dataset hub can
host it. ``download`` fetches with pooch, checks every file's sha256 against the registry,
keeps files already present and correct (resume), and refuses a corrupted one. For the
official splits the registry is the manifests committed in the package, so a mirror cannot
substitute other data; other splits take the mirror's ``registry.txt``.
"""

from __future__ import annotations

import os
import shutil
import tempfile
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType

from nsrmp_bench._optional import require
from nsrmp_bench.canonical import sha256_file
from nsrmp_bench.errors import DownloadError, InvalidArgument
from nsrmp_bench.official_manifests import official_manifest, official_manifest_text
from nsrmp_bench.split_specs import list_splits, load_split
from nsrmp_bench.storage.atomic import atomic_path, atomic_write_text
from nsrmp_bench.storage.contained import inside
from nsrmp_bench.storage.inputs_only import strip_part
from nsrmp_bench.storage.manifest import read_manifest
from nsrmp_bench.storage.split_root import split_root_parts

__all__ = ["MIRROR_ENV", "ByteProgress", "RegistryEntry", "download", "pack", "read_registry"]

MIRROR_ENV = "NSRMP_BENCH_MIRROR"
"""Environment variable holding the default mirror base URL."""
REGISTRY_NAME = "registry.txt"


@dataclass(frozen=True)
class RegistryEntry:
    """One released file: path relative to the split folder, sha256 and size."""

    path: str
    sha256: str
    bytes: int


def pack(data_dir: str | os.PathLike[str], out: str | os.PathLike[str], *,
         inputs_only: bool = False) -> list[RegistryEntry]:
    """Copy a generated split (``data_dir/<part>/``) into ``out/<split>/`` with its registry
    and its Croissant metadata (``croissant.json``, see :mod:`nsrmp_bench.export.croissant`;
    not in the registry, which lists only what ``download`` fetches).

    With ``inputs_only`` each part is written without its gold
    (:mod:`nsrmp_bench.storage.inputs_only`: what a scoring server's participants get) and
    no Croissant metadata, whose tables describe the gold."""
    src = Path(data_dir)
    parts = [src / p for p in split_root_parts(src)] or [src]
    if not (parts[0] / "manifest.json").is_file():
        msg = f"{src} holds no part directory with manifest.json; generate the split first"
        raise InvalidArgument(msg)
    entries: list[RegistryEntry] = []
    split_id = None
    for part_dir in parts:
        manifest = read_manifest(part_dir)
        sid, _, part = manifest.split.partition("/")
        if split_id not in (None, sid):
            msg = f"{src} mixes splits {split_id} and {sid}; pack one split at a time"
            raise InvalidArgument(msg)
        split_id = sid
        dest = Path(out) / sid / part
        dest.mkdir(parents=True, exist_ok=True)
        if inputs_only:
            strip_part(part_dir, dest)
        for name in [s.file for s in manifest.shards] + ["manifest.json"]:
            if not inputs_only:  # through a temporary name: a full disk leaves no shard
                with atomic_path(dest / name) as tmp:
                    shutil.copyfile(part_dir / name, tmp)
            size = (dest / name).stat().st_size
            entries.append(RegistryEntry(f"{part}/{name}", sha256_file(dest / name), size))
    if split_id is None:
        msg = f"{src} holds no manifest; generate the split first"
        raise InvalidArgument(msg)
    lines = [f"{e.path} {e.sha256} {e.bytes}" for e in entries]
    from nsrmp_bench.export.croissant import write_croissant

    packed_parts = sorted({e.path.split("/", 1)[0] for e in entries})
    if not inputs_only:
        write_croissant(Path(out) / split_id, split_id, packed_parts)
    atomic_write_text(
        Path(out) / split_id / REGISTRY_NAME,
        f"# nsrmp-bench release registry for {split_id}: <part>/<file> <sha256> <bytes>\n"
        + "\n".join(lines) + "\n",
    )
    return entries


def read_registry(text: str, where: str) -> list[RegistryEntry]:
    """Parse a registry file's text; bad lines name the line and the fix."""
    out = []
    for n, line in enumerate(text.splitlines(), 1):
        if not line.strip() or line.startswith("#"):
            continue
        fields = line.split()
        if len(fields) != 3 or len(fields[1]) != 64 or not fields[2].isdigit():
            msg = f"{where} line {n}: {line!r} is not '<part>/<file> <sha256> <bytes>'"
            raise DownloadError(msg)
        inside(Path("."), fields[0], what=f"{where} line {n}: the path", error=DownloadError,
               fix="a registry names '<part>/<file>' relative to the split's folder; use "
                   "another mirror or ask its maintainers to fix the registry")
        out.append(RegistryEntry(fields[0], fields[1], int(fields[2])))
    return out


def _official_registry(split_id: str) -> list[RegistryEntry] | None:
    """Shard entries from the committed manifests, or None if the split has none."""
    if split_id not in list_splits():
        return None
    entries: list[RegistryEntry] = []
    for part in load_split(split_id).parts:
        m = official_manifest(split_id, part)
        if m is None:
            return None
        entries.extend(RegistryEntry(f"{part}/{s['file']}", s["sha256"], int(s["bytes"]))
                       for s in m["shards"])
    return entries


def download(
    split_id: str,
    out: str | os.PathLike[str],
    *,
    base_url: str | None = None,
    trust_mirror_registry: bool = False,
    progress: bool = False,
    overwrite: bool = False,
) -> list[Path]:
    """Fetch ``split_id`` into ``out/<part>/``; every file checked against the registry.

    For an official split the registry is the committed manifests (the mirror's
    ``registry.txt`` is not read) and the committed ``manifest.json`` is written locally;
    otherwise, or with ``trust_mirror_registry``, the mirror's ``registry.txt`` is used.

    Every registry path must stay inside ``out`` (no absolute path, no ``..``, no link
    leading out): one that does not is a :class:`DownloadError` before anything is fetched.
    A file already in ``out`` that differs from the registry's is kept and refused, unless
    ``overwrite``.
    """
    pooch: ModuleType = require("pooch")
    pooch.get_logger().setLevel("WARNING")
    url = base_url or os.environ.get(MIRROR_ENV)
    if not url:
        msg = (
            f"no mirror given for {split_id}: pass --base-url URL or set {MIRROR_ENV}; "
            f"or generate it locally: nsrmp-bench generate --split {split_id} --out DIR"
        )
        raise DownloadError(msg)
    root = url.rstrip("/") + f"/{split_id}/"
    out_dir = Path(out)
    out_dir.mkdir(parents=True, exist_ok=True)
    registry = None if trust_mirror_registry else _official_registry(split_id)
    official = registry is not None
    if registry is None:
        with tempfile.TemporaryDirectory(prefix="nsrmp-registry-") as scratch:
            reg = _fetch(pooch, root + REGISTRY_NAME, Path(scratch), None)
            registry = read_registry(reg.read_text("utf-8"), root + REGISTRY_NAME)
    targets = [_target(out_dir, e, root + REGISTRY_NAME, overwrite=overwrite)
               for e in registry]
    files = [_fetch(pooch, root + e.path, out_dir, e, progress=progress, target=t)
             for e, t in zip(registry, targets, strict=True)]
    if official:  # the committed manifests are the registry: write them as they are
        for part in load_split(split_id).parts:
            text = official_manifest_text(split_id, part)
            local = out_dir / part / "manifest.json"
            if text is None or (local.is_file() and local.read_text("utf-8") == text):
                continue
            if local.exists() and not overwrite:
                msg = (f"{str(local)!r} exists and differs from the committed manifest of "
                       f"{split_id}/{part}; it was kept: move it away, download into another "
                       "folder, or pass --overwrite to replace it")
                raise DownloadError(msg)
            atomic_write_text(local, text)
    return files


def _is_hash_mismatch(exc: ValueError) -> bool:
    """True for pooch's "hash of downloaded file ... does not match" (and only that)."""
    text = str(exc)
    return "hash of downloaded file" in text and "does not match" in text


class ByteProgress:
    """A rich progress bar with the interface pooch drives (``total``, ``update``,
    ``reset``, ``close``), so downloads show progress without tqdm."""

    def __init__(self, description: str) -> None:
        from rich.progress import (
            BarColumn,
            DownloadColumn,
            Progress,
            TextColumn,
            TimeRemainingColumn,
            TransferSpeedColumn,
        )

        self._progress = Progress(TextColumn("{task.description}"), BarColumn(),
                                  DownloadColumn(), TransferSpeedColumn(),
                                  TimeRemainingColumn(), transient=False)
        self._task = self._progress.add_task(description, total=None)
        self._started = False

    @property
    def total(self) -> float | None:
        """Bytes expected (pooch sets it from the Content-Length)."""
        return self._progress.tasks[0].total

    @total.setter
    def total(self, value: float | None) -> None:
        if not self._started:
            self._progress.start()
            self._started = True
        self._progress.update(self._task, total=value or None)

    def update(self, n: float) -> None:
        """Advance by ``n`` bytes."""
        self._progress.advance(self._task, n)

    def reset(self) -> None:
        """Back to zero (pooch then fills the bar with the real total)."""
        self._progress.reset(self._task, total=self.total)

    def close(self) -> None:
        """Stop drawing."""
        if self._started:
            self._progress.stop()
            self._started = False


def _target(out_dir: Path, entry: RegistryEntry, where: str, *, overwrite: bool) -> Path:
    """Where ``entry`` goes: inside ``out_dir``, and not over a file that differs unasked."""
    target = inside(out_dir, entry.path, what=f"{where}: the path", error=DownloadError,
                    fix="a registry names '<part>/<file>' relative to the split's folder; "
                        "use another mirror or ask its maintainers to fix the registry")
    if target.is_symlink() or (target.exists() and not target.is_file()):
        msg = (f"{str(target)!r} exists and is not a plain file, where {entry.path!r} is to "
               "be downloaded; remove it or download into another folder")
        raise DownloadError(msg)
    if not overwrite and target.is_file() and sha256_file(target) != entry.sha256:
        msg = (f"{str(target)!r} exists and differs from the registry's {entry.path} (sha256 "
               f"{entry.sha256[:16]}...); it was kept: move it away, download into another "
               "folder, or pass --overwrite to replace it")
        raise DownloadError(msg)
    return target


def _fetch(pooch: ModuleType, url: str, out_dir: Path, entry: RegistryEntry | None,
           *, progress: bool = False, target: Path | None = None) -> Path:
    name = entry.path if entry is not None else REGISTRY_NAME
    target = target if target is not None else out_dir / name
    known = None if entry is None else f"sha256:{entry.sha256}"
    if entry is not None and target.is_file() and sha256_file(target) == entry.sha256:
        return target  # resume: already here and correct
    bar = ByteProgress(Path(name).name) if progress else False
    try:
        path = pooch.retrieve(url, known_hash=known, fname=Path(name).name,
                              path=target.parent, progressbar=bar)
    except ValueError as exc:
        if not _is_hash_mismatch(exc):  # pooch refused for another reason: say which
            msg = (
                f"{url}: pooch refused the download ({exc}); the file was not checked, so "
                "nothing is known about the mirror's copy: fix the cause named here, or "
                "download with --quiet"
            )
            raise DownloadError(msg) from exc
        msg = (
            f"{url}: the downloaded file does not match the registry's sha256 "
            f"{entry.sha256 if entry else ''} and was deleted ({exc}); the mirror's copy is "
            "corrupted: retry later or use another mirror"
        )
        raise DownloadError(msg) from exc
    except Exception as exc:  # requests/urllib errors: name the URL and the fix
        msg = f"could not fetch {url} ({type(exc).__name__}: {exc}); check the mirror URL"
        raise DownloadError(msg) from exc
    return Path(path)
