"""GDML files seen from the process that reads the configuration (no Geant4 here).

* :func:`gdml_files`: checks that a GDML file and everything it pulls in (``<!ENTITY ...
  SYSTEM "file">`` and ``<file name="..."/>``) are well-formed XML, naming file and line of the
  first fault (Geant4's reader, without validation, stops silently on broken XML);
* :func:`load_geometry_model`: the :class:`~score4.world.gdml_model.GeometryModel` of a GDML
  world, read by Geant4 in a subprocess (``python -m score4.geometry.gdml_reader``) and kept in
  score4's cache folder keyed by the content of all those files. The subprocess catches what
  Geant4 aborts on (a missing volume reference, an unreadable file) and reports Geant4's own
  message in one line.
"""

from __future__ import annotations

import hashlib
import json
import os
import subprocess
import sys
import tempfile
import xml.parsers.expat
from pathlib import Path

from .. import files as score4_files
from ..errors import ConfigError, Score4Error
from .gdml_model import MODEL_FORMAT, GeometryModel

#: Models read in this process, by cache key.
_MODELS: dict[str, GeometryModel] = {}


def _check_xml(path: Path, parameter: str, seen: list[Path]) -> None:
    """Parse ``path`` with expat (external entities followed); append every file read to
    ``seen``."""
    seen.append(path)
    parser = xml.parsers.expat.ParserCreate()
    parser.SetParamEntityParsing(xml.parsers.expat.XML_PARAM_ENTITY_PARSING_UNLESS_STANDALONE)

    def external(context, base, system_id, public_id):
        if system_id is None:
            return 1
        entity = (path.parent / system_id).resolve()
        if not entity.is_file():
            raise ConfigError(
                f"{parameter}: {path}: line {parser.CurrentLineNumber}: entity file "
                f"{system_id!r} not found ({entity})"
            )
        seen.append(entity)
        sub = parser.ExternalEntityParserCreate(context)
        try:
            sub.Parse(entity.read_bytes(), True)
        except xml.parsers.expat.ExpatError as err:
            raise ConfigError(
                f"{parameter}: {entity}: line {err.lineno}, column {err.offset}: not well-formed "
                f"XML ({xml.parsers.expat.errors.messages[err.code]})"
            ) from None
        return 1

    parser.ExternalEntityRefHandler = external
    try:
        parser.Parse(path.read_bytes(), True)
    except xml.parsers.expat.ExpatError as err:
        raise ConfigError(
            f"{parameter}: {path}: line {err.lineno}, column {err.offset}: not well-formed XML "
            f"({xml.parsers.expat.errors.messages[err.code]})"
        ) from None


#: The ``<userinfo>`` auxiliary legend-pygeom-tools writes detector metadata under (one
#: sub-auxiliary per physical volume: ``auxtype`` its name, ``auxvalue`` the metadata as JSON).
DETECTOR_METADATA_AUX = "RMG_detector_meta"


def detector_metadata(path: str | Path) -> dict[str, dict]:
    """Physical volume name -> metadata entry, from the GDML file's ``<userinfo>`` (the
    ``RMG_detector_meta`` auxiliary legend-pygeom-tools writes; LEGEND HPGe detectors carry
    their geometry there, :mod:`score4.shapes.hpge`). Empty when there is none; an entry whose
    value is not a JSON object is left out."""
    out: dict[str, dict] = {}
    stack: list[str] = []

    def start(name, attrs):
        parent = stack[-1] if stack else ""
        if name == "auxiliary" and parent == DETECTOR_METADATA_AUX:
            try:
                value = json.loads(attrs.get("auxvalue", ""))
            except ValueError:
                value = None
            if isinstance(value, dict) and attrs.get("auxtype"):
                out[attrs["auxtype"]] = value
        inside = name == "auxiliary" and attrs.get("auxtype") == DETECTOR_METADATA_AUX
        stack.append(DETECTOR_METADATA_AUX if inside and parent == "userinfo" else name)

    parser = xml.parsers.expat.ParserCreate()
    parser.SetParamEntityParsing(xml.parsers.expat.XML_PARAM_ENTITY_PARSING_UNLESS_STANDALONE)
    parser.ExternalEntityRefHandler = lambda *args: 1  # included files hold no userinfo
    parser.StartElementHandler = start
    parser.EndElementHandler = lambda name: stack.pop()
    parser.Parse(Path(path).read_bytes(), True)
    return out


def gdml_files(path: str | Path, parameter: str = "world.gdml") -> list[Path]:
    """The GDML file and every file it includes, all checked to be well-formed XML."""
    path = Path(path)
    if path.is_dir():
        raise ConfigError(f"{parameter}: {str(path)!r} is a folder, not a GDML file")
    if not path.is_file():
        raise ConfigError(f"{parameter}: GDML file {str(path)!r} does not exist")
    seen: list[Path] = []
    todo = [path.resolve()]
    while todo:
        current = todo.pop()
        if current in seen:
            continue
        before = len(seen)
        _check_xml(current, parameter, seen)
        for read in seen[before:]:
            refs = score4_files.gdml_include_refs(read.read_text(errors="replace"))
            for name in (name for kind, name, _ in refs if kind == "file"):  # entities: expat
                included = (current.parent / name).resolve()
                if not included.is_file():
                    raise ConfigError(
                        f"{parameter}: {read}: <file name={name!r}> not found ({included})"
                    )
                if included not in seen:
                    todo.append(included)
    return list(dict.fromkeys(seen))


def model_key(files: list[Path]) -> str:
    """Cache key of a GDML world: the model format and every file's name and content."""
    digest = hashlib.sha256(f"score4-gdml-model {MODEL_FORMAT}".encode())
    for f in files:
        digest.update(f.name.encode() + b"\0" + f.read_bytes() + b"\0")
    return digest.hexdigest()[:32]


def cache_dir() -> Path:
    """Where volume models are kept: ``$XDG_CACHE_HOME/score4/gdml-models``."""
    return score4_files.cache_dir("gdml-models")


def load_geometry_model(path: str | Path, parameter: str = "world.gdml") -> GeometryModel:
    """The volume model of the GDML world in ``path`` (read by Geant4 in a subprocess, cached)."""
    return keyed_geometry_model(path, parameter)[0]


def keyed_geometry_model(
    path: str | Path, parameter: str = "world.gdml"
) -> tuple[GeometryModel, str]:
    """:func:`load_geometry_model` and the model's :func:`model_key` (the content of all its
    files), from one reading of the files."""
    files = gdml_files(path, parameter)
    key = model_key(files)
    if key in _MODELS:
        return _MODELS[key], key
    cached = cache_dir() / f"{key}.json"
    data = None
    if cached.is_file():
        try:
            data = json.loads(cached.read_text())
        except (OSError, ValueError):
            data = None
    if data is None or data.get("format") != MODEL_FORMAT:
        data = _read_in_subprocess(files[0], parameter)
        data["files"] = [str(f) for f in files]
        try:
            cached.parent.mkdir(parents=True, exist_ok=True)
            with score4_files.atomic_output(cached) as tmp:
                tmp.write_text(json.dumps(data))
        except (OSError, Score4Error):
            pass  # no cache: the next command reads the GDML again
    data["source"] = str(path)
    model = GeometryModel.from_dict(data)
    _MODELS[key] = model
    return model, key


def _geant4_complaint(text: str) -> str | None:
    """Geant4's message of the first fatal G4Exception in its output, as one line."""
    lines = text.splitlines()
    for i, line in enumerate(lines):
        if "G4Exception :" in line and any("Fatal" in x for x in lines[i : i + 8]):
            code = line.split(":", 1)[1].strip()
            issuer = lines[i + 1].split(":", 1)[-1].strip() if i + 1 < len(lines) else ""
            message = []
            for follow in lines[i + 2 : i + 8]:
                if follow.startswith("***"):
                    break
                message.append(follow.strip())
            return f"{' '.join(message)} ({code} in {issuer})"
    return None


def _read_in_subprocess(path: Path, parameter: str) -> dict:
    with tempfile.TemporaryDirectory(prefix="score4-gdml-") as tmp:
        out = Path(tmp) / "model.json"
        proc = subprocess.run(
            [sys.executable, "-m", "score4.geometry.gdml_reader", str(path), str(out)],
            capture_output=True,
            text=True,
            env={**os.environ, "PYTHONUNBUFFERED": "1"},
            check=False,
        )
        text = proc.stdout + "\n" + proc.stderr
        if proc.returncode == 0 and out.is_file():
            return json.loads(out.read_text())
    complaint = _geant4_complaint(text)
    if complaint is None:
        said = [x.strip() for x in text.splitlines() if x.strip().startswith("score4:")]
        complaint = (
            said[-1].removeprefix("score4:").strip()
            if said
            else f"Geant4's reader failed (exit status {proc.returncode}): "
            + " | ".join(x.strip() for x in text.strip().splitlines()[-3:])
        )
    raise ConfigError(f"{parameter}: {path}: {complaint}")
