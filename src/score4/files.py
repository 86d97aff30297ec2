"""Writing files so that nothing already written is lost or half-written."""

from __future__ import annotations

import contextlib
import io
import os
import re
import shutil
import tempfile
from collections.abc import Callable, Iterator, Mapping
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


#: Characters the temporary file beside an output adds to its name (``.NAME.XXXXXXXX.partial``).
_TMP_EXTRA = 18
#: Image formats the plotting commands write (matplotlib's names, chosen by the file suffix).
IMAGE_FORMATS = ("png", "pdf", "svg", "eps", "ps", "jpg", "jpeg", "tif", "tiff", "webp")
# An include of a GDML file: ``<file name="f.gdml"/>`` (not ``volname``) or an external XML
# entity ``<!ENTITY m SYSTEM "materials.xml">`` (also ``<!ENTITY % m SYSTEM ...>``), either quote.
_GDML_INCLUDE = re.compile(
    r"""<file\b[^>]*?\bname\s*=\s*["'](?P<file>[^"']+)["']"""
    r"""|<!ENTITY\s[^>]*?SYSTEM\s+["'](?P<entity>[^"']+)["']"""
)
_INCLUDES_READ = 64 * 2**20  # bytes of a GDML file searched for <file> includes


def gdml_include_refs(text: str) -> list[tuple[str, str, tuple[int, int]]]:
    """The includes written in GDML ``text``, in order: ``(kind, name, span)`` with kind
    ``"file"`` (``<file name=...>``) or ``"entity"`` (``<!ENTITY ... SYSTEM ...>``), the name
    as written (relative to the including file's folder, usually) and its span in ``text``.

    The one reader of GDML includes: :func:`gdml_includes` follows them, the world's volume
    model checks them (:func:`score4.world.gdml_files.gdml_files`) and the GDML export moves
    them to the output's folder (:func:`score4.geometry.gdml_splice.relink`).
    """
    out = []
    for m in _GDML_INCLUDE.finditer(text):
        kind = "file" if m.group("file") is not None else "entity"
        out.append((kind, m.group(kind), m.span(kind)))
    return out


def gdml_includes(path: str | os.PathLike) -> list[Path]:
    """The files a GDML file pulls in with ``<file name=...>`` or an XML entity (``<!ENTITY m
    SYSTEM "materials.xml">``), recursively, relative to the including file's folder (as
    :func:`score4.geometry.gdml.read_gdml` reads them)."""
    found: list[Path] = []
    todo = [Path(path)]
    seen: set[Path] = set()
    while todo:
        current = todo.pop()
        try:
            key = current.resolve()
            if key in seen or not current.is_file():
                continue
            seen.add(key)
            with open(current, "rb") as f:
                text = f.read(_INCLUDES_READ).decode("utf-8", "replace")
        except (OSError, RuntimeError):
            continue
        for _, name, _ in gdml_include_refs(text):
            child = current.parent / name
            found.append(child)
            todo.append(child)
    return found


def with_includes(
    inputs: Mapping[str, str | os.PathLike | None],
) -> dict[str, str | os.PathLike]:
    """``inputs`` plus the files their GDML files include (``{what: path}``)."""
    out: dict[str, str | os.PathLike] = {}
    for what, source in inputs.items():
        if source is None:
            continue
        out[what] = source
        if str(source).lower().endswith(".gdml"):
            for child in gdml_includes(source):
                out.setdefault(f"the file {str(child)!r} included by {what}", child)
    return out


def _name_max(folder: Path) -> int:
    try:
        return int(os.pathconf(folder, "PC_NAME_MAX"))
    except (OSError, ValueError, AttributeError):
        return 255


def check_output_file(
    path: str | os.PathLike,
    overwrite: bool,
    option: str = "--out",
    inputs: Mapping[str, str | os.PathLike | None] | None = None,
) -> Path:
    """``path`` as a Path, after the checks every command makes before writing a file.

    Its folder must exist and be writable, it must not be a folder, its name must fit the file
    system (with the temporary file written beside it), it must not be one of the command's
    ``inputs`` (``{what: path}``, with the files their GDML files include; not even with
    ``overwrite``: the output would replace what it is made from), and an existing file is
    replaced only with ``overwrite`` (the command's ``--overwrite``). Errors are
    :class:`ConfigError` naming ``option`` (the command-line option that gave the path).
    Commands with several outputs call :func:`check_outputs`.
    """
    path = Path(path)
    if not path.name or path.name in (".", ".."):
        raise ConfigError(f"{option}: {str(path)!r} is a folder, not a file name")
    for what, source in with_includes(inputs or {}).items():
        if same_file(path, source):
            raise ConfigError(
                f"{option}: {str(path)!r} is {what}; an output never replaces an input, even "
                "with --overwrite: choose another file name"
            )
    folder = path.parent if str(path.parent) else Path(".")
    for up in (folder, *folder.parents):
        if up.exists() and not up.is_dir():
            raise ConfigError(
                f"{option}: {str(up)!r} is a file, not a folder: {str(path)!r} cannot be written"
            )
    if not folder.is_dir():
        raise ConfigError(f"{option}: folder {str(folder)!r} does not exist (create it first)")
    if not os.access(folder, os.W_OK):
        raise ConfigError(f"{option}: folder {str(folder)!r} is not writable")
    longest = _name_max(folder) - _TMP_EXTRA
    if len(os.fsencode(path.name)) > longest:
        raise ConfigError(
            f"{option}: the file name {path.name[:40]!r}... has {len(os.fsencode(path.name))} "
            f"bytes, more than the {longest} this file system allows (255 less room for the "
            "temporary file written beside it): choose a shorter name"
        )
    if path.is_dir():
        raise ConfigError(f"{option}: {str(path)!r} is a folder, not a file name")
    if path.exists() and not overwrite:
        raise ConfigError(f"{option}: {str(path)!r} already exists; use --overwrite to replace it")
    return path


def check_image_file(path: str | os.PathLike, option: str) -> None:
    """Refuse an image file name whose suffix names no format the plots can write."""
    path = Path(path)
    fmt = path.suffix.lower().lstrip(".") or "png"
    if fmt not in IMAGE_FORMATS:
        raise ConfigError(
            f"{option}: unknown image format {path.suffix!r} in {str(path)!r}; use one of: "
            + ", ".join(f".{f}" for f in sorted(IMAGE_FORMATS))
        )


def check_outputs(
    outputs: Mapping[str, str | os.PathLike | None],
    overwrite: bool,
    inputs: Mapping[str, str | os.PathLike | None] | None = None,
    images: tuple[str, ...] = (),
) -> dict[str, Path]:
    """The one rule for every command's outputs, checked before anything is written.

    ``outputs`` maps each output option to its path (None: not asked for). Every output passes
    :func:`check_output_file` against every input (``{what: path}``, GDML includes followed),
    no two outputs are the same file, and the options in ``images`` name a known image
    format. Returns the outputs given, as Paths.
    """
    given = {option: Path(p) for option, p in outputs.items() if p is not None}
    every_input = with_includes(inputs or {})
    seen: dict[str, Path] = {}
    for option, path in given.items():
        for other, earlier in seen.items():
            if same_file(path, earlier):
                raise ConfigError(
                    f"{option}: {str(path)!r} is also the output of {other}; every output "
                    "needs a file of its own"
                )
        check_output_file(path, overwrite, option, every_input)
        if option in images:
            check_image_file(path, option)
        seen[option] = path
    return given


@contextlib.contextmanager
def atomic_output(
    path: str | os.PathLike,
    check: Callable[[Path], str | None] | None = None,
    suffix: str = ".partial",
) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; rename it over ``path`` only if the block succeeds.

    A failure (disk full, permissions, an exception in the block) leaves any existing ``path``
    untouched and removes the temporary file; ``OSError`` becomes a :class:`Score4Error` naming
    the file. The write is checked before the rename: the temporary file must exist, and
    ``check(tmp)`` (for writers that do not report a failed write, such as Geant4's GDML
    writer on a full disk) returns None or why the file is incomplete.
    """
    path = Path(path)
    try:
        fd, name = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=suffix)
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
        if not tmp.is_file():
            raise Score4Error(f"cannot write {path}: the writer left no file")
        why = check(tmp) if check is not None else None
        if why:
            raise Score4Error(f"cannot write {path}: {why} (is the disk full?)")
        os.replace(tmp, path)
    except OSError as err:
        tmp.unlink(missing_ok=True)
        raise Score4Error(f"cannot write {path}: {err}") from err
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


def ends_with(tail: bytes, what: str) -> Callable[[Path], str | None]:
    """A ``check`` for :func:`atomic_output`: the file must end with ``tail`` (after white
    space), as a complete XML document ends with its root's closing tag."""

    def check(tmp: Path) -> str | None:
        size = tmp.stat().st_size
        with open(tmp, "rb") as f:
            f.seek(max(0, size - 4096))
            end = f.read().rstrip()
        return None if end.endswith(tail) else f"the {what} written is incomplete ({size} bytes)"

    return check


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
