"""The volume tree of a GDML world as plain data: no Geant4 here.

A :class:`GeometryModel` is what score4 knows about a GDML world without importing Geant4 in
the process that reads the configuration: its logical volumes (solid type and parameters,
material, daughters with their placement transforms as Geant4 computed them) and its materials
(density, elements with Z and isotopes). A small Geant4 subprocess makes it
(:func:`score4.geometry.gdml.load_geometry_model`), and it is cached on disk keyed by the GDML
content.

Every physical volume of the world is an :class:`Instance`: one path of placements from the
world down. A logical volume placed three times, or a volume inside a mother placed three times,
gives three instances with the same name; ``name`` means all of them and ``name[k]`` the
``k``-th in tree order (``score4 geometry list`` shows the index). Global transforms are composed
along the placement chain: ``global = R_mother (R local + t) + t_mother``.
"""

from __future__ import annotations

import difflib
import fnmatch
import re
from collections.abc import Iterator
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from ..errors import ConfigError
from ..shapes import Transform

#: Format of the stored model (bump when its contents change: cached models are made again).
# 4: with the GDML's own overlaps (gdml_reader.own_overlaps); 5: with detector metadata;
# 7: G4Trap described (6 was used by pre-merge runs of s7-solids, whose cached models lack 5's
# metadata); 8: tessellated and extruded solids with one face per plane (MeshShape.by_planes)
MODEL_FORMAT = 8

#: Most instances the tree is expanded to (a world of nested tiling holds millions of cells).
MAX_INSTANCES = 200_000

_REF = re.compile(r"^(?P<name>.+?)(?:\[(?P<index>\d+)\])?$")


@dataclass(frozen=True)
class Placement:
    """A daughter of a logical volume: physical volume name, copy number, what it places, where.

    ``rotation`` is the object rotation (the daughter's axes in the mother frame, columns) and
    ``translation`` its origin in the mother frame, as Geant4 holds them
    (``GetObjectRotationValue``, ``GetTranslation``). ``kind`` is ``placement``, ``replica`` or
    ``parameterised`` (the last two stand for ``multiplicity`` volumes and are not expanded).
    """

    name: str
    copy: int
    logical: int
    rotation: np.ndarray
    translation: np.ndarray
    kind: str = "placement"
    multiplicity: int = 1


@dataclass(frozen=True)
class Logical:
    """A logical volume: its solid (type, name, parameters, volume, area), material, daughters."""

    name: str
    solid: dict
    material: str
    daughters: tuple[Placement, ...]

    @property
    def solid_type(self) -> str:
        return str(self.solid["type"])

    @property
    def reflected(self) -> bool:
        return self.solid_type == "G4ReflectedSolid"


@dataclass(frozen=True, eq=False)
class Instance:
    """One physical volume of the world (a path of placements from the world volume)."""

    index: int
    path: tuple[int, ...]  # daughter indices from the world's logical volume down
    name: str
    copy: int
    logical: int
    mother: int | None  # instance index of the mother (None for the world)
    rotation: np.ndarray  # global: columns are the volume's axes in the world
    translation: np.ndarray  # global origin of the volume's frame
    occurrence: int  # k: this is name[k]
    reflected: bool  # a reflection on the chain (the solid or a mother is a G4ReflectedSolid)
    replicated: bool  # inside a replica or parameterised volume (transform not known here)

    @property
    def depth(self) -> int:
        return len(self.path)

    @cached_property
    def transform(self) -> Transform:
        """The volume's frame -> the world."""
        return Transform(self.rotation, self.translation)

    def to_world(self, local: np.ndarray) -> np.ndarray:
        return self.transform.apply(local)

    def to_local(self, world: np.ndarray) -> np.ndarray:
        return self.transform.inverse_apply(world)


def _shared_start(a: str, b: str) -> int:
    """Length of the start two names share."""
    n = 0
    while n < min(len(a), len(b)) and a[n] == b[n]:
        n += 1
    return n


@dataclass
class GeometryModel:
    """Logical volumes, materials and the expanded instance tree of a GDML world."""

    source: str  # the GDML file it was read from
    world: int  # index of the world's logical volume
    world_name: str  # the world's physical volume name
    logicals: list[Logical]
    materials: dict[str, dict]
    files: list[str] = field(default_factory=list)  # the GDML file and the files it includes
    # the file's own overlaps found by Geant4 when it was read: {"volumes": [a, b], "by": "1 mm"}
    overlaps: list[dict] = field(default_factory=list)
    # physical volume name -> detector metadata from the GDML's <userinfo> (gdml_files.
    # detector_metadata): a LEGEND HPGe's entry names its surfaces (score4.shapes.hpge)
    metadata: dict[str, dict] = field(default_factory=dict)

    # -- plain data ------------------------------------------------------------------------------

    @classmethod
    def from_dict(cls, data: dict) -> GeometryModel:
        logicals = [
            Logical(
                lv["name"],
                lv["solid"],
                lv["material"],
                tuple(
                    Placement(
                        d["name"],
                        int(d["copy"]),
                        int(d["logical"]),
                        np.asarray(d["rotation"], float).reshape(3, 3),
                        np.asarray(d["translation"], float),
                        d.get("kind", "placement"),
                        int(d.get("multiplicity", 1)),
                    )
                    for d in lv["daughters"]
                ),
            )
            for lv in data["logicals"]
        ]
        return cls(
            data["source"],
            int(data["world"]),
            data["world_name"],
            logicals,
            data["materials"],
            list(data.get("files", [])),
            list(data.get("overlaps", [])),
            dict(data.get("metadata", {})),
        )

    def to_dict(self) -> dict:
        return {
            "format": MODEL_FORMAT,
            "source": self.source,
            "world": self.world,
            "world_name": self.world_name,
            "files": self.files,
            "overlaps": self.overlaps,
            "metadata": self.metadata,
            "materials": self.materials,
            "logicals": [
                {
                    "name": lv.name,
                    "solid": lv.solid,
                    "material": lv.material,
                    "daughters": [
                        {
                            "name": d.name,
                            "copy": d.copy,
                            "logical": d.logical,
                            "rotation": d.rotation.ravel().tolist(),
                            "translation": d.translation.tolist(),
                            "kind": d.kind,
                            "multiplicity": d.multiplicity,
                        }
                        for d in lv.daughters
                    ],
                }
                for lv in self.logicals
            ],
        }

    # -- the instance tree -----------------------------------------------------------------------

    @cached_property
    def instances(self) -> list[Instance]:
        """Every physical volume in tree order (depth first), the world first; at most
        :data:`MAX_INSTANCES` (see :attr:`truncated`)."""
        out: list[Instance] = []
        counts: dict[str, int] = {}
        stack: list[tuple] = [
            ((), self.world_name, 0, self.world, None, np.eye(3), np.zeros(3), False, False)
        ]
        while stack and len(out) < MAX_INSTANCES:
            path, name, copy, lv, mother, rot, t, refl, repl = stack.pop()
            k = counts.get(name, 0)
            counts[name] = k + 1
            logical = self.logicals[lv]
            refl = refl or logical.reflected
            inst = Instance(len(out), path, name, copy, lv, mother, rot, t, k, refl, repl)
            out.append(inst)
            for i in reversed(range(len(logical.daughters))):
                d = logical.daughters[i]
                stack.append(
                    (
                        (*path, i),
                        d.name,
                        d.copy,
                        d.logical,
                        inst.index,
                        rot @ d.rotation,
                        rot @ d.translation + t,
                        refl,
                        repl or d.kind != "placement",
                    )
                )
        self._truncated = bool(stack)
        return out

    @property
    def truncated(self) -> bool:
        """True when the world holds more than :data:`MAX_INSTANCES` volumes (not all expanded)."""
        _ = self.instances
        return self._truncated

    @cached_property
    def by_name(self) -> dict[str, list[int]]:
        """Physical volume name -> instance indices (tree order)."""
        table: dict[str, list[int]] = {}
        for inst in self.instances:
            table.setdefault(inst.name, []).append(inst.index)
        return table

    @cached_property
    def by_logical_name(self) -> dict[str, list[int]]:
        """Logical volume name -> instance indices (tree order)."""
        table: dict[str, list[int]] = {}
        for inst in self.instances:
            table.setdefault(self.logicals[inst.logical].name, []).append(inst.index)
        return table

    @cached_property
    def children(self) -> dict[int, list[int]]:
        table: dict[int, list[int]] = {}
        for inst in self.instances:
            if inst.mother is not None:
                table.setdefault(inst.mother, []).append(inst.index)
        return table

    def daughters(self, inst: Instance) -> list[Instance]:
        return [self.instances[i] for i in self.children.get(inst.index, [])]

    def label(self, inst: Instance) -> str:
        """``name`` when the name is unique, else ``name[k]``."""
        return inst.name if len(self.by_name[inst.name]) == 1 else f"{inst.name}[{inst.occurrence}]"

    # -- names -----------------------------------------------------------------------------------

    def resolve(self, ref: str, parameter: str) -> list[Instance]:
        """The instances ``ref`` names: a physical volume name (all its copies), ``name[k]`` (one),
        or a logical volume name (all its placements) when no physical volume has that name.

        Raises :class:`ConfigError` naming ``parameter`` with the closest names.
        """
        m = _REF.match(ref.strip())
        name, index = (m.group("name"), m.group("index")) if m else (ref, None)
        hits = self.by_name.get(name) or self.by_logical_name.get(name)
        if not hits:
            names = list(self.by_name) + [n for n in self.by_logical_name if n not in self.by_name]
            close = difflib.get_close_matches(name, names, n=5, cutoff=0.5)
            shown = [self._with_copies(c) for c in close]
            hint = f"; closest: {', '.join(shown)}" if close else ""
            more = " (the tree was cut at MAX_INSTANCES volumes)" if self.truncated else ""
            raise ConfigError(
                f"{parameter}: no volume named {name!r} in {self.source}{hint}{more}; "
                f"`score4 geometry list {self.source}` lists the volumes"
            )
        if index is None:
            return [self.instances[i] for i in hits]
        k = int(index)
        if k >= len(hits):
            raise ConfigError(
                f"{parameter}: {ref!r}: {name!r} has {len(hits)} cop"
                f"{'y' if len(hits) == 1 else 'ies'} ({name}[0] to {name}[{len(hits) - 1}])"
            )
        return [self.instances[hits[k]]]

    def select(
        self, glob: str | None, regex: str | None, material: str | None, parameter: str
    ) -> list[Instance]:
        """The volumes (the world excluded) whose physical volume name matches the glob
        pattern ``glob`` and the regular expression ``regex`` (the whole name) and whose
        material is ``material`` (each if given). Raises :class:`ConfigError` naming
        ``parameter`` and the closest names when none does."""
        rx = re.compile(regex) if regex is not None else None
        hits = [
            inst
            for inst in self.instances[1:]
            if (glob is None or fnmatch.fnmatchcase(inst.name, glob))
            and (rx is None or rx.fullmatch(inst.name))
            and (material is None or self.logicals[inst.logical].material == material)
        ]
        if hits:
            return hits
        what = []
        if glob is not None:
            what.append(f"matches {glob!r}")
        if regex is not None:
            what.append(f"matches the regular expression {regex!r}")
        if material is not None:
            what.append(f"is of material {material!r}")
        materials = sorted({self.logicals[i.logical].material for i in self.instances[1:]})
        if material is not None and material not in materials:
            close = difflib.get_close_matches(material, materials, n=5, cutoff=0.3)
            hint = f"; closest materials: {', '.join(close or materials[:5])}"
        elif material is not None and (glob is not None or regex is not None):
            named = [  # the name matches, the material does not: say what those are made of
                inst
                for inst in self.instances[1:]
                if (glob is None or fnmatch.fnmatchcase(inst.name, glob))
                and (rx is None or rx.fullmatch(inst.name))
            ]
            have = sorted({self.logicals[i.logical].material for i in named})
            hint = (
                f"; the volumes that match are of {', '.join(have)}"
                if have
                else f"; closest names: {', '.join(self.closest_names(glob or regex or ''))}"
            )
        else:
            hint = f"; closest names: {', '.join(self.closest_names(glob or regex or ''))}"
        raise ConfigError(
            f"{parameter}: no volume of {self.source} {' and '.join(what)}{hint}; "
            f"`score4 geometry list {self.source}` lists the volumes"
        )

    def closest_names(self, pattern: str, n: int = 5) -> list[str]:
        """Up to ``n`` volume names (the world excluded) closest to a glob or regular
        expression: :mod:`difflib`'s close matches to its literal characters; failing those,
        the names sharing the longest start with its literal head (``V0*``: ``V02160B``, ...);
        failing those, the best :mod:`difflib` ratios (never empty while the world holds a
        volume)."""
        names = list(dict.fromkeys(i.name for i in self.instances[1:]))
        special = r"[*?\[\]^$.+(){}|\\]"
        bare = re.sub(special, "", pattern)
        close = difflib.get_close_matches(bare, names, n=n, cutoff=0.5) if bare else []
        if close:
            return close
        head = re.split(special, pattern, maxsplit=1)[0]
        shared = {m: _shared_start(head, m) for m in names}
        best = max(shared.values(), default=0)
        if best:
            return [m for m in names if shared[m] == best][:n]
        return sorted(names, key=lambda m: -difflib.SequenceMatcher(None, bare, m).ratio())[:n]

    def column(self, inst: Instance) -> str:
        """The scoring column of a volume a pattern selects: its name, ``name_k`` for copy k
        of a name with several copies."""
        return inst.name if len(self.by_name[inst.name]) == 1 else f"{inst.name}_{inst.occurrence}"

    def _with_copies(self, name: str) -> str:
        n = len(self.by_name.get(name) or self.by_logical_name.get(name) or [])
        return name if n == 1 else f"{name} ({name}[0]..{name}[{n - 1}])"

    # -- sizes -----------------------------------------------------------------------------------

    def density(self, material: str) -> float:
        """g/cm3."""
        return float(self.materials[material]["density_g_cm3"])

    def own_volume(self, lv: int) -> float:
        """mm3 of the logical volume's own material: its solid less its daughters' solids."""
        logical = self.logicals[lv]
        total = float(logical.solid["volume_mm3"])
        for d in logical.daughters:
            total -= d.multiplicity * float(self.logicals[d.logical].solid["volume_mm3"])
        return total

    def own_mass(self, lv: int) -> float:
        """kg of the logical volume's own material (daughters excluded)."""
        return self.own_volume(lv) * self.density(self.logicals[lv].material) * 1e-6

    # -- listing -----------------------------------------------------------------------------------

    def rows(self) -> Iterator[dict]:
        """One row per instance, as ``score4 geometry list --json`` prints them."""
        own: dict[int, tuple[float, float]] = {}  # per logical volume: (volume, mass)
        for inst in self.instances:
            lv = self.logicals[inst.logical]
            if inst.logical not in own:
                own[inst.logical] = (self.own_volume(inst.logical), self.own_mass(inst.logical))
            volume, mass = own[inst.logical]
            yield {
                "name": inst.name,
                "index": inst.occurrence,
                "label": self.label(inst),
                "copy": inst.copy,
                "depth": inst.depth,
                "mother": None if inst.mother is None else self.label(self.instances[inst.mother]),
                "logical": lv.name,
                "solid": lv.solid_type,
                "solid_name": lv.solid.get("name"),
                "parameters": lv.solid.get("params", {}),
                "material": lv.material,
                "density_g_cm3": self.density(lv.material),
                "volume_mm3": volume,
                "mass_kg": mass,
                "area_mm2": float(lv.solid["area_mm2"]),
                "position_mm": inst.translation.tolist(),
                "rotation": inst.rotation.tolist(),
                "reflected": inst.reflected,
                "replicated": inst.replicated,
            }
