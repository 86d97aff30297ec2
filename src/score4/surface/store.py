"""The score4 surface file: one HDF5 file with the full description and the height data.

Layout (lengths in mm, ``units`` attributes say so)::

    attrs: format = "score4-surface", format_version, kind, spec (JSON of the description),
           metadata (JSON: provenance, e.g. the measured file's reader metadata)
    /heightmap/heights   (ny, nx) primary height map (random and measured surfaces); attrs
                         pitch_x, pitch_y, origin
    /spikes/heights      (ny, nx) the drawn spike heights (spike grids)

A spike grid is rebuilt from its description and checked against the stored heights; random
and measured surfaces are read from the stored map, so a measured surface no longer needs the
instrument file.
"""

from __future__ import annotations

import json
from pathlib import Path

import h5py
import numpy as np

from ..errors import ConfigError
from ..files import atomic_h5, open_h5
from .heightmap import HeightMap
from .spec import Surface, build_surface, parse_surface_spec

FORMAT = "score4-surface"
FORMAT_VERSION = 1
SUFFIX = ".s4s.h5"


def _jsonable(metadata: dict) -> str:
    return json.dumps(metadata, default=str, sort_keys=True)


def save_surface(surface: Surface, path: str | Path) -> Path:
    """Write ``surface`` to ``path`` atomically (an existing file is replaced only on success)."""
    path = Path(path)
    with atomic_h5(path) as f:
        f.attrs["format"] = FORMAT
        f.attrs["format_version"] = FORMAT_VERSION
        f.attrs["kind"] = surface.spec.kind
        f.attrs["spec"] = surface.spec.model_dump_json()
        hm = surface.heightmap
        f.attrs["metadata"] = _jsonable(
            {**(hm.metadata if hm is not None else {}), **surface.metadata}
        )
        if surface.spikes is not None:
            f.create_dataset("spikes/heights", data=surface.spikes.heights).attrs["units"] = "mm"
        else:
            assert hm is not None  # a surface holds spikes or a height map
            d = f.create_dataset("heightmap/heights", data=hm.heights, compression="gzip")
            d.attrs["units"] = "mm"
            d.attrs["pitch_x"], d.attrs["pitch_y"] = hm.pitch_x, hm.pitch_y
            d.attrs["origin"] = np.asarray(hm.origin, dtype=float)
    return path


def load_surface(path: str | Path) -> Surface:
    """Read a surface file written by :func:`save_surface`."""
    path = Path(path)
    with open_h5(path, FORMAT, "surface file", ConfigError) as f:
        try:
            return _read(f, path)
        except (
            KeyError,
            ValueError,
            TypeError,
        ) as err:  # ConfigError is a ValueError: keep its message
            if isinstance(err, ConfigError):
                raise
            raise ConfigError(
                f"surface file: {path} is damaged or incomplete ({type(err).__name__}: {err})"
            ) from None


def _read(f: h5py.File, path: Path) -> Surface:
    version = int(f.attrs["format_version"])
    if version > FORMAT_VERSION:
        raise ConfigError(
            f"surface file: {path} has format version {version}; this score4 reads up to "
            f"{FORMAT_VERSION}"
        )
    spec = parse_surface_spec(
        json.loads(f.attrs["spec"]), origin=f"{path} (stored description)", stored=True
    )
    metadata = json.loads(f.attrs.get("metadata", "{}"))
    if "spikes" in f:
        stored = f["spikes/heights"][...]
        spikes = build_surface(spec).spikes
        if (
            spikes is None
            or spikes.heights.shape != stored.shape
            or not np.array_equal(spikes.heights, stored)
        ):
            raise ConfigError(
                f"surface file: {path}: the spike heights rebuilt from the stored description "
                "differ from the stored heights (file written by an incompatible score4 version?)"
            )
        return Surface(spec, spikes=spikes, metadata=metadata)
    d = f["heightmap/heights"]
    hm = HeightMap(
        d[...],
        float(d.attrs["pitch_x"]),
        float(d.attrs["pitch_y"]),
        origin=(float(d.attrs["origin"][0]), float(d.attrs["origin"][1])),
        metadata=metadata,
    )
    return Surface(spec, heightmap=hm, metadata=metadata)


def stored_spec(path: str | Path):
    """The description stored in a surface file (its attributes only, no height data), or None
    if the file cannot be read as one."""
    try:
        with h5py.File(path, "r") as f:
            if f.attrs.get("format") != FORMAT:
                return None
            return parse_surface_spec(json.loads(f.attrs["spec"]), stored=True)
    except (OSError, KeyError, ValueError, TypeError):
        return None
