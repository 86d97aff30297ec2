"""Writing files so that nothing already written is lost or half-written."""

from __future__ import annotations

import contextlib
import io
import os
import shutil
import tempfile
from collections.abc import Iterator, Mapping
from pathlib import Path

import h5py

from .errors import ConfigError, Score4Error

FREE_SPACE_MARGIN = 256 * 1024  # bytes kept free beyond a file's size


def cache_dir(*parts: str) -> Path:
    """score4's folder under the user cache, ``$XDG_CACHE_HOME/score4/...`` (``~/.cache``)."""
    base = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")
    return base.joinpath("score4", *parts)


def same_file(a: str | os.PathLike, b: str | os.PathLike) -> bool:
    """True if ``a`` and ``b`` name the same file: equal resolved paths, or (both existing) the
    same file on disk (hard links, other spellings through symbolic links)."""
    a, b = Path(a), Path(b)
    try:
        if a.resolve() == b.resolve():
            return True
        return a.exists() and b.exists() and os.path.samefile(a, b)
    except (OSError, RuntimeError):  # a symlink loop: they cannot be read, let the caller fail
        return False


def check_output_file(
    path: str | os.PathLike,
    overwrite: bool,
    option: str = "--out",
    inputs: Mapping[str, str | os.PathLike | None] | None = None,
) -> Path:
    """``path`` as a Path, after the checks every command makes before writing a file.

    Its folder must exist and be writable, it must not be a folder, it must not be one of the
    command's ``inputs`` (``{what: path}``; not even with ``overwrite``: the output would
    replace what it is made from), and an existing file is replaced only with ``overwrite``
    (the command's ``--overwrite``). Errors are :class:`ConfigError` naming ``option`` (the
    command-line option that gave the path).
    """
    path = Path(path)
    for what, source in (inputs or {}).items():
        if source is not None and same_file(path, source):
            raise ConfigError(
                f"{option}: {str(path)!r} is {what}; an output never replaces an input, even "
                "with --overwrite: choose another file name"
            )
    folder = path.parent if str(path.parent) else Path(".")
    if not folder.is_dir():
        raise ConfigError(f"{option}: folder {str(folder)!r} does not exist (create it first)")
    if not os.access(folder, os.W_OK):
        raise ConfigError(f"{option}: folder {str(folder)!r} is not writable")
    if path.is_dir():
        raise ConfigError(f"{option}: {str(path)!r} is a folder, not a file name")
    if path.exists() and not overwrite:
        raise ConfigError(f"{option}: {str(path)!r} already exists; use --overwrite to replace it")
    return path


@contextlib.contextmanager
def atomic_output(path: str | os.PathLike):
    """Yield a temporary path beside ``path``; rename it over ``path`` only if the block succeeds.

    A failure (disk full, permissions, an exception in the block) leaves any existing ``path``
    untouched and removes the temporary file; ``OSError`` becomes a :class:`Score4Error` naming
    the file.
    """
    path = Path(path)
    try:
        fd, name = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".partial")
    except OSError as err:
        raise Score4Error(f"cannot write {path}: {err}") from err
    os.close(fd)
    tmp = Path(name)
    try:
        # mkstemp makes the file private (0600); give the result the usual umask-based mode
        umask = os.umask(0)
        os.umask(umask)
        tmp.chmod(0o666 & ~umask)
        yield tmp
        os.replace(tmp, path)
    except OSError as err:
        tmp.unlink(missing_ok=True)
        raise Score4Error(f"cannot write {path}: {err}") from err
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


def check_free_space(path: str | os.PathLike, nbytes: int) -> None:
    """Refuse to write a file of about ``nbytes`` to ``path`` when its disk cannot hold it.

    An early, clear refusal (with the figures) for the usual case, a disk filling up. It cannot
    see quotas, file-size limits or other writers: :func:`atomic_h5` is safe without it.
    """
    free = shutil.disk_usage(Path(path).parent).free
    need = int(nbytes) + FREE_SPACE_MARGIN
    if free < need:
        raise Score4Error(
            f"cannot write {path}: the disk is full ({free / 1e6:.2f} MB free, about "
            f"{need / 1e6:.2f} MB needed with a safety margin)"
        )


@contextlib.contextmanager
def atomic_h5(path: str | os.PathLike) -> Iterator[h5py.File]:
    """Yield a new HDF5 file that appears at ``path`` only when the block succeeds.

    HDF5 writes into an in-memory image; the finished image then goes to disk with plain
    Python I/O through :func:`atomic_output`. Why: h5py 3.16 / HDF5 2.0 crash the process with
    a segmentation fault when a write to disk fails (a full disk, a quota, a file-size limit;
    h5py issue #914). Plain I/O turns that failure into a :class:`Score4Error` naming the file,
    and any existing ``path`` stays untouched. The cost: the whole file is held in memory
    once while it is written (see docs/cluster.md).
    """
    path = Path(path)
    image = io.BytesIO()  # grows by ~1/8 when full: at most ~12 % unused
    with h5py.File(image, "w") as f:
        yield f
    check_free_space(path, image.getbuffer().nbytes)
    with atomic_output(path) as tmp, open(tmp, "wb") as out:
        out.write(image.getbuffer())


def open_h5(
    path: str | os.PathLike, fmt: str, label: str, error: type[Score4Error] = Score4Error
) -> h5py.File:
    """Open a score4 HDF5 file for reading: it must exist, be HDF5 and carry ``format = fmt``.

    Errors are ``error`` instances whose message starts with ``label`` (e.g. "source.vertices").
    """
    path = Path(path)
    if not path.is_file():
        raise error(f"{label}: {str(path)!r} does not exist")
    try:
        f = h5py.File(path, "r")
    except OSError as err:
        raise error(f"{label}: {path} is not an HDF5 file ({err})") from None
    if f.attrs.get("format") != fmt:
        f.close()
        raise error(
            f"{label}: {path} is not a {fmt.replace('-', ' ')} file (no format={fmt!r} attribute)"
        )
    return f
