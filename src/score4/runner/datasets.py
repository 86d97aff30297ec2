"""Geant4 data sets: the official list, where they are, which physics they allow, installing them.

The official list (names, versions, tarball names, environment variables, md5 sums) and the
download URL are read from the installed geant4_pybind extension, which embeds its ``datainit``
module as source text. This module never imports geant4_pybind: importing it without
``GEANT4_DATA_DIR`` set would prompt on stdin or start a download.

A data set ``<name><version>`` is searched, in this order, through its own environment variable
(e.g. ``G4LEDATA``), ``$GEANT4_DATA_DIR/<name><version>``, geant4_pybind's cache
``~/.geant4_pybind/<name><version>`` and score4's data folder (:func:`default_data_dir`).
A folder counts only if some regular file below it is non-empty, so score4's "lite" stub (an
empty ``ENSDFSTATE.dat``) is never taken for real data.
"""

from __future__ import annotations

import ast
import enum
import functools
import hashlib
import importlib.util
import mmap
import os
import re
import shlex
import shutil
import sys
import tempfile
import warnings
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path, PurePosixPath
from typing import IO, TYPE_CHECKING, Any, cast

from score4.errors import ConfigError, DataError

if TYPE_CHECKING:  # the network and tar modules are imported where a download needs them
    import http.client
    import tarfile

__all__ = [
    "DECAY",
    "FULL_EM",
    "MODES",
    "DataSet",
    "DataSetStatus",
    "Source",
    "available_modes",
    "dataset_url",
    "default_data_dir",
    "export_line",
    "geant4_env",
    "install",
    "locate",
    "locate_with_source",
    "missing_for",
    "official_datasets",
    "status",
]

#: Data sets needed by full EM physics (G4EmStandardPhysics_option4 aborts without G4EMLOW).
FULL_EM: tuple[str, ...] = ("G4EMLOW", "G4ENSDFSTATE")
#: Data sets needed by radioactive decay (G4RadioactiveDecayPhysics).
DECAY: tuple[str, ...] = ("G4ENSDFSTATE", "PhotonEvaporation", "RadioactiveDecay")
#: Physics mode -> data sets it needs. ``lite`` runs with no data at all.
MODES: dict[str, tuple[str, ...]] = {"lite": (), "full": FULL_EM, "decay": DECAY}

_OFFICIAL_URL = "https://cern.ch/geant4-data/datasets"
_URL_ENV = "SCORE4_DATASET_URL"
_CHUNK = 1 << 16
_TMP_PREFIX = ".score4-tmp-"


@dataclass(frozen=True)
class DataSet:
    """One official Geant4 data set.

    Parameters
    ----------
    name : str
        Data-set name, e.g. ``"G4EMLOW"``.
    version : str
        Version string, e.g. ``"8.8"``.
    filename : str
        Tarball stem on the server, e.g. ``"G4PhotonEvaporation"``.
    envvar : str
        Environment variable Geant4 reads for this set, e.g. ``"G4LEDATA"``.
    md5 : str
        md5 hex digest of the tarball.
    """

    name: str
    version: str
    filename: str
    envvar: str
    md5: str

    @property
    def dirname(self) -> str:
        """Folder the tarball unpacks to, e.g. ``G4EMLOW8.8``."""
        return self.name + self.version

    @property
    def tarball(self) -> str:
        """Tarball file name on the server, e.g. ``G4EMLOW.8.8.tar.gz``."""
        return f"{self.filename}.{self.version}.tar.gz"


# geant4_pybind 0.1.3 (Geant4 11.4.1); used only if the extension cannot be read.
_FALLBACK_0_1_3: tuple[DataSet, ...] = (
    DataSet("G4NDL", "4.7.1", "G4NDL", "G4NEUTRONHPDATA", "54f0ed3995856f02433d42ec96d70bc6"),
    DataSet("G4EMLOW", "8.8", "G4EMLOW", "G4LEDATA", "328330009df633f7e9b3a9f445745298"),
    DataSet(
        "PhotonEvaporation",
        "6.1.2",
        "G4PhotonEvaporation",
        "G4LEVELGAMMADATA",
        "d80ba9bdefcf9e23487a26adfa273304",
    ),
    DataSet(
        "RadioactiveDecay",
        "6.1.2",
        "G4RadioactiveDecay",
        "G4RADIOACTIVEDATA",
        "20d494f73d4bddabd7fab5c06a58895c",
    ),
    DataSet(
        "G4PARTICLEXS",
        "4.2",
        "G4PARTICLEXS",
        "G4PARTICLEXSDATA",
        "b63341cc97a472b04ff607b094493174",
    ),
    DataSet("G4PII", "1.3", "G4PII", "G4PIIDATA", "05f2471dbcdf1a2b17cbff84e8e83b37"),
    DataSet(
        "RealSurface",
        "2.2",
        "G4RealSurface",
        "G4REALSURFACEDATA",
        "ea8f1cfa8d8aafd64b71fb30b3e8a6d9",
    ),
    DataSet("G4SAIDDATA", "2.0", "G4SAIDDATA", "G4SAIDXSDATA", "d5d4e9541120c274aeed038c621d39da"),
    DataSet("G4ABLA", "3.3", "G4ABLA", "G4ABLADATA", "b25d093339e1e4532e31038653580ca6"),
    DataSet("G4INCL", "1.3", "G4INCL", "G4INCLDATA", "72c3ff5f7f1e6f727f2ebf3b11ce784f"),
    DataSet(
        "G4ENSDFSTATE",
        "3.0",
        "G4ENSDFSTATE",
        "G4ENSDFSTATEDATA",
        "c500728534ce3e9fb2fefa0112eb3a74",
    ),
    DataSet(
        "G4CHANNELING",
        "2.0",
        "G4CHANNELING",
        "G4CHANNELINGDATA",
        "e853fbcba1e8640f7c3a437253955482",
    ),
)

# The list ends at a "]" alone on its line; entries never contain one.
_DATASETS_RE = re.compile(rb"DATASETS\s*=\s*(\[.*?^\])", re.MULTILINE | re.DOTALL)
_URL_RE = re.compile(rb"DATASET_URL\s*=\s*(\"[^\"\n]*\"|'[^'\n]*')", re.MULTILINE)
_MD5_RE = re.compile(r"[0-9a-f]{32}")


# --------------------------------------------------------------------------- official list


def _extension_path() -> Path | None:
    """Path of the geant4_pybind extension module, found without importing it."""
    try:
        spec = importlib.util.find_spec("geant4_pybind")
    except (ImportError, ValueError):
        return None
    if spec is None or not spec.origin or not os.path.isfile(spec.origin):
        return None
    return Path(spec.origin)


def _search_extension(pattern: re.Pattern[bytes], anchor: bytes, path: Path) -> bytes | None:
    """First group of ``pattern`` matched at a line starting with ``anchor`` in ``path``.

    The ~80 MB file is memory-mapped and scanned with ``find`` (fast) before the regex is
    tried at each hit, which a full-file regex search would make ~20x slower.
    """
    with open(path, "rb") as fh, mmap.mmap(fh.fileno(), 0, access=mmap.ACCESS_READ) as data:
        pos = data.find(b"\n" + anchor)
        while pos >= 0:
            match = pattern.match(data, pos + 1)
            if match:
                return bytes(match.group(1))
            pos = data.find(b"\n" + anchor, pos + 1)
    return None


def _to_dataset(entry: Any) -> DataSet:
    """Validate one entry of the embedded ``DATASETS`` list."""
    if not isinstance(entry, dict):
        raise ValueError(f"entry {entry!r} is not a dict")
    keys = ("name", "version", "filename", "envvar", "md5sum")
    values = [value for key in keys if isinstance(value := entry.get(key), str) and value]
    if len(values) != len(keys):
        raise ValueError(f"entry {entry!r} lacks a name/version/filename/envvar/md5sum string")
    if not _MD5_RE.fullmatch(values[4]):
        raise ValueError(f"entry {entry!r} has an md5sum that is not 32 hex digits")
    return DataSet(*values)


def _parse_extension(path: Path) -> tuple[DataSet, ...]:
    """Parse the ``DATASETS`` list embedded in the extension at ``path``."""
    block = _search_extension(_DATASETS_RE, b"DATASETS", path)
    if block is None:
        raise ValueError("no 'DATASETS = [...]' block found")
    entries = ast.literal_eval(block.decode("utf-8"))
    if not isinstance(entries, list) or not entries:
        raise ValueError("'DATASETS' is not a non-empty list")
    return tuple(_to_dataset(entry) for entry in entries)


@functools.cache
def _official() -> tuple[DataSet, ...]:
    path = _extension_path()
    try:
        if path is None:
            raise ValueError("geant4_pybind is not installed")
        return _parse_extension(path)
    except (OSError, ValueError, SyntaxError, UnicodeDecodeError) as exc:
        # Cached, so this warns once per process.
        warnings.warn(
            f"cannot read the Geant4 data-set list from geant4_pybind ({exc}); "
            "using score4's built-in list for geant4_pybind 0.1.3",
            RuntimeWarning,
            stacklevel=3,
        )
        return _FALLBACK_0_1_3


def official_datasets() -> list[DataSet]:
    """The official Geant4 data sets of the installed geant4_pybind.

    Returns
    -------
    list of DataSet
        In geant4_pybind's order. Falls back (with one warning) to the built-in list of
        geant4_pybind 0.1.3 if the extension cannot be read.
    """
    return list(_official())


@functools.cache
def dataset_url() -> str:
    """The official download URL of the data sets (from geant4_pybind, else the known one)."""
    path = _extension_path()
    try:
        found = _search_extension(_URL_RE, b"DATASET_URL", path) if path is not None else None
    except OSError:
        found = None
    try:
        url = ast.literal_eval(found.decode("utf-8")) if found is not None else None
    except (ValueError, SyntaxError, UnicodeDecodeError):
        url = None
    if isinstance(url, str) and url.startswith(("https://", "http://")):
        return url
    return _OFFICIAL_URL


def _by_name(names: Iterable[str]) -> list[DataSet]:
    """Official data sets for ``names``; unknown names raise DataError listing the valid ones."""
    catalog = {ds.name: ds for ds in official_datasets()}
    unknown = [name for name in names if name not in catalog]
    if unknown:
        raise DataError(
            f"only={', '.join(unknown)}: unknown data-set name; valid names are "
            f"{', '.join(catalog)}"
        )
    return [catalog[name] for name in dict.fromkeys(names)]


# --------------------------------------------------------------------------- locating


class Source(enum.StrEnum):
    """Where a data set was found."""

    ENVVAR = "envvar"  #: the set's own variable, e.g. $G4LEDATA
    GEANT4_DATA_DIR = "GEANT4_DATA_DIR"  #: $GEANT4_DATA_DIR/<name><version>
    GEANT4_PYBIND = "geant4_pybind"  #: ~/.geant4_pybind/<name><version>
    SCORE4 = "score4"  #: default_data_dir()/<name><version>


def _env_path(env: Mapping[str, str], key: str) -> Path | None:
    """``env[key]`` as a user-expanded path, or None when unset or empty."""
    value = env.get(key, "")
    return Path(value).expanduser() if value else None


def _home(env: Mapping[str, str]) -> Path:
    return _env_path(env, "HOME") or Path.home()


def default_data_dir(env: Mapping[str, str] | None = None) -> Path:
    """score4's own data folder.

    Parameters
    ----------
    env : mapping, optional
        Environment to read (default ``os.environ``).

    Returns
    -------
    Path
        ``$SCORE4_DATA_DIR`` if set, else ``$XDG_DATA_HOME/score4/geant4-data`` with
        ``XDG_DATA_HOME`` defaulting to ``~/.local/share``.
    """
    env = os.environ if env is None else env
    explicit = _env_path(env, "SCORE4_DATA_DIR")
    if explicit is not None:
        return explicit
    xdg = _env_path(env, "XDG_DATA_HOME") or _home(env) / ".local" / "share"
    return xdg / "score4" / "geant4-data"


def _has_data(folder: Path) -> bool:
    """True if ``folder`` is a directory with a non-empty regular file somewhere below it."""
    if not folder.is_dir():
        return False
    pending = [folder]
    while pending:
        try:
            with os.scandir(pending.pop()) as entries:
                for entry in entries:
                    # Symlinked files count; symlinked folders are not entered (no loops).
                    if entry.is_file() and entry.stat().st_size > 0:
                        return True
                    if entry.is_dir(follow_symlinks=False):
                        pending.append(Path(entry.path))
        except OSError:
            continue  # unreadable sub-folder: it cannot supply data
    return False


def _candidates(ds: DataSet, env: Mapping[str, str]) -> list[tuple[Path, Source]]:
    """Folders where ``ds`` may be, in search order."""
    found: list[tuple[Path, Source]] = []
    own = _env_path(env, ds.envvar)
    if own is not None:
        found.append((own, Source.ENVVAR))
    g4dir = _env_path(env, "GEANT4_DATA_DIR")
    if g4dir is not None:
        found.append((g4dir / ds.dirname, Source.GEANT4_DATA_DIR))
    found.append((_home(env) / ".geant4_pybind" / ds.dirname, Source.GEANT4_PYBIND))
    found.append((default_data_dir(env) / ds.dirname, Source.SCORE4))
    return found


def locate_with_source(
    ds: DataSet, env: Mapping[str, str] | None = None
) -> tuple[Path, Source] | None:
    """Find a data set and say where it came from.

    Parameters
    ----------
    ds : DataSet
        The data set.
    env : mapping, optional
        Environment to read (default ``os.environ``).

    Returns
    -------
    (Path, Source) or None
        The first folder holding real data (see module docstring), or None.
    """
    env = os.environ if env is None else env
    for folder, source in _candidates(ds, env):
        if _has_data(folder):
            return folder, source
    return None


def locate(ds: DataSet, env: Mapping[str, str] | None = None) -> Path | None:
    """Folder of data set ``ds``, or None if missing (see :func:`locate_with_source`)."""
    hit = locate_with_source(ds, env)
    return hit[0] if hit else None


# --------------------------------------------------------------------------- status and modes


@dataclass(frozen=True)
class DataSetStatus:
    """Where one official data set is, if anywhere.

    Attributes
    ----------
    name, version, envvar : str
        As in :class:`DataSet`.
    path : Path or None
        Folder holding the data, None if missing.
    source : Source or None
        Where ``path`` was found, None if missing.
    """

    name: str
    version: str
    envvar: str
    path: Path | None
    source: Source | None

    @property
    def found(self) -> bool:
        """True if the data set is installed."""
        return self.path is not None

    def to_dict(self) -> dict[str, str | None]:
        """JSON-ready form."""
        return {
            "name": self.name,
            "version": self.version,
            "envvar": self.envvar,
            "path": None if self.path is None else str(self.path),
            "source": None if self.source is None else str(self.source),
        }


def status(env: Mapping[str, str] | None = None) -> list[DataSetStatus]:
    """Status of every official data set, in the official order."""
    env = os.environ if env is None else env
    result = []
    for ds in official_datasets():
        hit = locate_with_source(ds, env)
        path, source = hit or (None, None)
        result.append(DataSetStatus(ds.name, ds.version, ds.envvar, path, source))
    return result


def missing_for(mode: str, statuses: Sequence[DataSetStatus]) -> list[str]:
    """Names of the data sets that physics ``mode`` needs and that are missing.

    Parameters
    ----------
    mode : {"lite", "full", "decay"}
        Physics mode.
    statuses : sequence of DataSetStatus
        As returned by :func:`status`.

    Raises
    ------
    ConfigError
        If ``mode`` is not a known mode.
    """
    if mode not in MODES:
        raise ConfigError(
            f"mode={mode!r}: unknown physics mode; valid modes are {', '.join(MODES)}"
        )
    found = {s.name for s in statuses if s.found}
    return [name for name in MODES[mode] if name not in found]


def available_modes(statuses: Sequence[DataSetStatus]) -> dict[str, bool]:
    """Which physics modes the data allow: ``lite`` (always True), ``full``, ``decay``."""
    return {mode: not missing_for(mode, statuses) for mode in MODES}


def geant4_env(statuses: Sequence[DataSetStatus]) -> dict[str, str]:
    """Per-set Geant4 environment variables (e.g. ``G4LEDATA``) for every data set found.

    Setting these before importing geant4_pybind makes Geant4 use exactly the folders
    reported by :func:`status`, whichever source they came from.
    """
    return {s.envvar: str(s.path) for s in statuses if s.path is not None}


def export_line(directory: str | os.PathLike[str]) -> str:
    """The shell line that points Geant4 at ``directory``: ``export GEANT4_DATA_DIR=...``."""
    return f"export GEANT4_DATA_DIR={shlex.quote(str(Path(directory).expanduser().absolute()))}"


# --------------------------------------------------------------------------- downloading


def _offline_hint(directory: Path) -> str:
    return (
        "fetch the data sets on a machine with internet and copy them here as "
        f"{directory}/<name><version>/ (e.g. {directory}/G4EMLOW8.8/), "
        f"then {export_line(directory)}"
    )


def _open_url(url: str, timeout: float, directory: Path) -> http.client.HTTPResponse:
    """Open ``url``; every network failure becomes a one-line DataError."""
    import http.client
    import urllib.error
    import urllib.request

    try:
        response = urllib.request.urlopen(url, timeout=timeout)  # the official or the user's URL
        return cast(http.client.HTTPResponse, response)
    except urllib.error.HTTPError as exc:
        reason = f"HTTP {exc.code} {exc.reason}"
    except urllib.error.URLError as exc:
        reason = str(exc.reason)
    except (OSError, http.client.HTTPException, ValueError) as exc:
        reason = str(exc) or type(exc).__name__
    raise DataError(f"cannot download {url}: {reason}; {_offline_hint(directory)}")


def _content_length(response: http.client.HTTPResponse) -> int | None:
    value = response.headers.get("Content-Length")
    return int(value) if value and value.isdigit() else None


def _network_error(url: str, exc: BaseException, directory: Path) -> DataError:
    """One-line DataError for a network failure while reading ``url``."""
    return DataError(
        f"download of {url} failed: {str(exc) or type(exc).__name__}; {_offline_hint(directory)}"
    )


def _stream(
    response: http.client.HTTPResponse,
    out: IO[bytes],
    url: str,
    label: str,
    directory: Path,
    progress: bool,
) -> tuple[int, int | None, str]:
    """Copy the body to ``out``; return bytes read, announced length and md5 hex digest."""
    import http.client

    from tqdm import tqdm  # imported here: only downloads need it

    total = _content_length(response)
    digest = hashlib.md5()  # what geant4_pybind publishes; not for security
    done = 0
    with tqdm(
        total=total,
        unit="B",
        unit_scale=True,
        unit_divisor=1024,
        desc=label,
        file=sys.stderr,
        disable=not progress,
    ) as bar:
        while True:
            try:
                chunk = response.read(_CHUNK)
            except (OSError, http.client.HTTPException) as exc:
                raise _network_error(url, exc, directory) from exc
            if not chunk:
                break
            out.write(chunk)
            digest.update(chunk)
            done += len(chunk)
            bar.update(len(chunk))
    return done, total, digest.hexdigest()


def _download(
    ds: DataSet, url: str, tarball: Path, directory: Path, timeout: float, progress: bool
) -> None:
    """Download ``url`` into ``tarball`` and check its length and md5.

    ``directory`` is the install target, named in the error messages.
    """
    response = _open_url(url, timeout, directory)
    try:
        with response, open(tarball, "wb") as out:
            done, total, md5 = _stream(response, out, url, ds.tarball, directory, progress)
    except OSError as exc:  # network errors were turned into DataError: this is the disk
        raise DataError(f"cannot write {tarball}: {exc}") from exc
    if total is not None and done != total:
        raise DataError(
            f"download of {url} ended after {done} of {total} bytes (connection lost); "
            f"retry, or {_offline_hint(directory)}"
        )
    if md5 != ds.md5:
        raise DataError(f"md5 mismatch for {ds.tarball} from {url}: expected {ds.md5}, got {md5}")


# --------------------------------------------------------------------------- unpacking


def _check_member(member: tarfile.TarInfo, dirname: str, tarball: str) -> None:
    """Refuse absolute paths, ``..``, members outside ``<dirname>/`` and device files."""
    parts = PurePosixPath(member.name).parts
    rule = None
    if member.name.startswith("/"):
        rule = "absolute paths are refused"
    elif ".." in parts:
        rule = "'..' is refused (path traversal)"
    elif not parts or parts[0] != dirname:
        rule = f"every member must lie in {dirname}/"
    elif not (member.isfile() or member.isdir() or member.issym() or member.islnk()):
        rule = "only files, folders and links are accepted"
    if rule:
        raise DataError(f"tarball {tarball}: member {member.name!r} refused: {rule}")


def _extract_checked(tarball: Path, into: Path, dirname: str) -> Path:
    """Extract ``tarball`` into the empty folder ``into``, member by member, after checks.

    Returns the extracted ``into/<dirname>`` folder.
    """
    import tarfile

    try:
        with tarfile.open(tarball, "r:*") as tar:
            for member in tar:
                _check_member(member, dirname, tarball.name)
                tar.extract(member, into, filter="data")
    except (tarfile.TarError, EOFError, OSError) as exc:
        raise DataError(f"tarball {tarball.name} cannot be unpacked: {exc}") from exc
    top = into / dirname
    if os.listdir(into) != [dirname] or not top.is_dir() or not _has_data(top):
        raise DataError(
            f"tarball {tarball.name}: content must be exactly one non-empty folder {dirname}/, "
            f"found {sorted(os.listdir(into))}"
        )
    return top


def _move_into_place(extracted: Path, target: Path, scratch: Path) -> None:
    """Rename ``extracted`` to ``target``; an old, invalid ``target`` goes to ``scratch`` first."""
    if target.exists() or target.is_symlink():
        # e.g. score4's lite stub or an empty folder: set it aside, removed with the scratch.
        os.replace(target, scratch / "replaced")
    try:
        os.replace(extracted, target)
    except OSError as exc:
        if not _has_data(target):  # else another process has just installed the same set
            raise DataError(f"cannot move {extracted} to {target}: {exc}") from exc


def _remove(path: Path) -> None:
    """Remove a temp file or folder, ignoring what is already gone."""
    if path.is_dir() and not path.is_symlink():
        shutil.rmtree(path, ignore_errors=True)
    else:
        path.unlink(missing_ok=True)


def _install_one(
    ds: DataSet, directory: Path, base_url: str, timeout: float, progress: bool
) -> Path:
    """Download, verify and atomically unpack one data set into ``directory``."""
    url = f"{base_url.rstrip('/')}/{ds.tarball}"
    try:
        scratch = Path(tempfile.mkdtemp(prefix=f"{_TMP_PREFIX}{ds.dirname}-", dir=directory))
    except OSError as exc:
        raise DataError(f"directory={str(directory)!r}: cannot write into it: {exc}") from exc
    try:
        tarball = scratch / ds.tarball
        _download(ds, url, tarball, directory, timeout, progress)
        unpacked = scratch / "unpacked"
        unpacked.mkdir()
        extracted = _extract_checked(tarball, unpacked, ds.dirname)
        tarball.unlink()  # free the space before the rename; the data are complete
        target = directory / ds.dirname
        _move_into_place(extracted, target, scratch)
        return target
    finally:
        # Runs on errors and on KeyboardInterrupt alike: no temp file outlives the call.
        _remove(scratch)


def _wanted(only: Sequence[str] | None, env: Mapping[str, str]) -> list[DataSet]:
    """The sets ``install`` must provide: ``only``, or every official set found nowhere."""
    if isinstance(only, str):
        only = [only]
    if only is not None:
        return _by_name(only)
    return [ds for ds in official_datasets() if locate(ds, env) is None]


def install(
    directory: str | os.PathLike[str] | None = None,
    only: Sequence[str] | None = None,
    base_url: str | None = None,
    progress: bool = True,
    timeout: float = 60,
) -> list[Path]:
    """Download, verify and unpack official Geant4 data sets.

    Each tarball is streamed to a temporary file inside ``directory``, its length and md5
    are checked, it is unpacked into a temporary folder there (members outside the expected
    ``<name><version>/`` folder, absolute paths and ``..`` are refused) and the folder is then
    renamed into place. An interrupted install leaves neither temp files nor a partial set.

    Parameters
    ----------
    directory : path, optional
        Target folder (default :func:`default_data_dir`); created if needed.
    only : sequence of str, optional
        Names of the sets to install. Default: every official set that :func:`locate`
        finds nowhere. Sets already present in ``directory`` are not downloaded again.
    base_url : str, optional
        Server folder holding the tarballs. Default ``$SCORE4_DATASET_URL`` if set, else
        the official URL (:func:`dataset_url`).
    progress : bool
        Show a tqdm progress bar on stderr.
    timeout : float
        Socket timeout in seconds for connecting and for each read.

    Returns
    -------
    list of Path
        Folders of the requested sets inside ``directory`` (installed now or already there).

    Raises
    ------
    DataError
        Unknown name in ``only``, network failure, short download, md5 mismatch, or a
        tarball with unexpected content.
    """
    if timeout <= 0:
        raise ConfigError(f"timeout={timeout!r}: must be a positive number of seconds")
    env = os.environ
    target_dir = Path(directory).expanduser() if directory is not None else default_data_dir(env)
    url = base_url or env.get(_URL_ENV) or dataset_url()
    wanted = _wanted(only, env)
    try:
        target_dir.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise DataError(f"directory={str(target_dir)!r}: cannot create it: {exc}") from exc
    return [
        target_dir / ds.dirname
        if _has_data(target_dir / ds.dirname)
        else _install_one(ds, target_dir, url, timeout, progress)
        for ds in wanted
    ]
