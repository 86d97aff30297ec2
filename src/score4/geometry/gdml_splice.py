"""``score4 geometry export`` of a GDML world: the user's file, text kept, rough layers added.

The user's GDML text is edited in place (no XML library re-writes it): every definition,
material, solid, volume, physical volume, ``<auxiliary>`` and the ``<userinfo>`` block stay as
they were, byte for byte. score4's additions are written by Geant4's own writer in a separate
small world (the rough layers' envelopes, cells, groups and patches, with their placements in
the coordinates of the GDML volume that is their mother; the cut solids of ``into: true``
targets; configured boxes) and spliced in:

* their definitions, solids and volumes go to the end of ``<define>``, ``<solids>`` and the start
  of ``<structure>`` (they refer to nothing of the user's but materials), under names of their
  own: Geant4's pointer suffixes dropped and ``_<n>`` added where a name is taken (by the user's
  file or by another addition), so every name is unique and readers that look names up
  (pyg4ometry) read the file;
* materials are referred to by the user's names (a NIST ``G4_`` material the file does not define
  by its NIST name); a material of score4's configuration is added;
* the envelope of each rough layer (and each configured box) is one more ``<physvol>`` of its
  mother's ``<volume>``;
* a volume score4 must copy (one copy of a shared logical volume roughened or scored alone,
  see :mod:`score4.geometry.gdml_world`) becomes a new ``<volume>`` ``<name>_u<k>``, the text of
  the original with a new name, and its placement on that path refers to it;
* ``into: true`` gives the target volume its cut solid and its placement the shifted position.

remage (LEGEND's Geant4 application) registers sensitive detectors from the ``<userinfo>``
block as legend-pygeom-tools writes it: ``<auxiliary auxtype="RMG_detector" auxvalue="germanium">``
holding one ``<auxiliary auxtype="PHYSVOL" auxvalue="UID"/>`` per detector, registered with copy
number 0; legend-pygeom-tools writes a volume that shares a detector's UID as
``auxvalue=":UID,true,TABLE"`` (UID reuse allowed, the steps written to the table ``TABLE``).
For every target registered there, the physical volumes of its rough layer's patch bodies (the
detector's material) are added to the same group as ``":UID,true,<target>"``: remage counts
their deposits for that detector, in its table. Patch placements are written with copy number 0
(the number a GDML registration looks up; a patch volume is placed once, in its cell box).
"""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import ConfigError, Score4Error
from ..files import gdml_include_refs

_DAUGHTER = re.compile(
    r"<(physvol|replicavol|paramvol|divisionvol)\b[^>]*?(?:/>|>.*?</\1\s*>)", re.DOTALL
)
_VOLUME = re.compile(
    r"<(volume|assembly)\b[^>]*?\bname\s*=\s*\"([^\"]*)\"[^>]*>.*?</\1\s*>", re.DOTALL
)
_NAME = re.compile(r"\bname\s*=\s*\"([^\"]*)\"")
_VOLUMEREF = re.compile(r"<volumeref\b[^>]*?\bref\s*=\s*\"([^\"]*)\"")
_POINTER = re.compile(r"^(.*?)0x[0-9a-fA-F]+(.*)$")


def strip_pointer(name: str) -> str:
    """A GDML name as Geant4's reader names the object (everything from ``0x`` on removed)."""
    i = name.find("0x")
    return name if i < 0 else name[:i]


@dataclass
class _Section:
    """The text of one top-level section (``define``, ``materials``, ...) of the user's file."""

    start: int  # offset of the text after the opening tag (or of a self-closed tag)
    end: int  # offset of the closing tag
    empty: bool = False  # written as <name/>


def _section(text: str, tag: str) -> _Section | None:
    m = re.search(rf"<{tag}\b[^>]*?(/?)>", text)
    if m is None:
        return None
    if m.group(1):
        return _Section(m.start(), m.end(), empty=True)
    close = text.find(f"</{tag}", m.end())
    if close < 0:
        raise ConfigError(f"world.gdml: <{tag}> is not closed")
    return _Section(m.end(), close)


@dataclass
class UserFile:
    """The user's GDML text as items of ``<structure>`` that can be edited one by one."""

    head: str  # everything before the content of <structure>
    items: list[list[str]]  # [kind, name, text]: kind 'volume', 'assembly' or 'text'
    tail: str  # from </structure> on
    names: set[str] = field(default_factory=set)  # every name="..." of the file
    world: str = ""

    @classmethod
    def parse(cls, text: str) -> UserFile:
        s = _section(text, "structure")
        if s is None or s.empty:
            raise ConfigError("world.gdml: the file has no <structure> (is it in an entity?)")
        body = text[s.start : s.end]
        items: list[list[str]] = []
        pos = 0
        for m in _VOLUME.finditer(body):
            if m.start() > pos:
                items.append(["text", "", body[pos : m.start()]])
            items.append([m.group(1), m.group(2), m.group(0)])
            pos = m.end()
        items.append(["text", "", body[pos:]])
        world = re.search(r"<world\b[^>]*?\bref\s*=\s*\"([^\"]*)\"", text[s.end :])
        if world is None:
            raise ConfigError("world.gdml: the file has no <setup> with a <world ref=...>")
        return cls(
            text[: s.start],
            items,
            text[s.end :],
            set(_NAME.findall(text)),
            world.group(1),
        )

    def text(self) -> str:
        return self.head + "".join(item[2] for item in self.items) + self.tail

    def index(self, name: str) -> int:
        for i, (kind, n, _) in enumerate(self.items):
            if kind == "volume" and n == name:
                return i
        raise ConfigError(
            f"world.gdml: volume {name!r} is not in the file's own text (an entity or a <file> "
            "include?); the export keeps the user's file only when the volumes score4 adds to "
            "are in it"
        )

    def daughters(self, name: str) -> list[re.Match]:
        return list(_DAUGHTER.finditer(self.items[self.index(name)][2]))

    def assemblies(self) -> set[str]:
        return {n for kind, n, _ in self.items if kind == "assembly"}

    def daughter(self, mother: str, i: int) -> tuple[re.Match, str]:
        """The ``i``-th daughter element of volume ``mother`` and the volume it places."""
        ds = self.daughters(mother)
        assemblies = self.assemblies()
        refs = [_VOLUMEREF.search(d.group(0)) for d in ds]
        if any(r is not None and r.group(1) in assemblies for r in refs[: i + 1]):
            raise ConfigError(
                f"world.gdml: volume {mother!r} places an <assembly>; the export keeps the "
                "user's file only where the path to a target has no assembly"
            )
        d, ref = ds[i], refs[i]
        if d.group(1) != "physvol" or ref is None or "<file" in d.group(0):
            raise ConfigError(
                f"world.gdml: daughter {i} of {mother!r} is not a plain <physvol> of a volume of "
                "this file"
            )
        return d, ref.group(1)

    def replace_daughter(self, mother: str, i: int, new: str) -> None:
        k = self.index(mother)
        d = self.daughters(mother)[i]
        t = self.items[k][2]
        self.items[k][2] = t[: d.start()] + new + t[d.end() :]

    def add_daughters(self, mother: str, physvols: str) -> None:
        """Add placements to volume ``mother``: after its last daughter (before its
        ``<auxiliary>`` elements, if any, or its end)."""
        k = self.index(mother)
        t = self.items[k][2]
        aux = t.find("<auxiliary")
        at = _line_start(t, aux if aux >= 0 else t.rfind("</volume"))
        self.items[k][2] = t[:at] + physvols + t[at:]

    def clone(self, name: str, new: str) -> None:
        k = self.index(name)
        text = self.items[k][2]
        m = _NAME.search(text)
        assert m is not None
        copy = text[: m.start(1)] + new + text[m.end(1) :]
        self.items.insert(k + 1, ["volume", new, copy])
        self.items.insert(k + 1, ["text", "", "\n    "])
        self.names.add(new)


def _line_start(text: str, at: int) -> int:
    """``at`` moved back to the start of its line when only blanks precede it there."""
    start = text.rfind("\n", 0, at) + 1
    return start if not text[start:at].strip() else at


def _unique(base: str, taken: set[str], serial: Counter[str]) -> str:
    """``base``, or ``base_<n>`` with the next free ``n`` (``serial`` counts per base)."""
    if base not in taken:
        taken.add(base)
        return base
    n = serial[base]
    while True:
        n += 1
        if f"{base}_{n}" not in taken:
            break
    serial[base] = n
    taken.add(f"{base}_{n}")
    return f"{base}_{n}"


class Walker:
    """Finds the user's volumes along model paths and unshares them, as
    :class:`score4.geometry.gdml_world._Unsharer` does in Geant4 (same order, same choices), on
    the text."""

    def __init__(self, user: UserFile, model) -> None:
        self.user = user
        self.model = model
        self.counts = Counter(inst.logical for inst in model.instances)
        self.clones: set[str] = set()

    def path(self, inst) -> tuple[str, int, str]:
        """``(mother volume name, daughter index, volume name)`` of instance ``inst`` (the world:
        ``("", -1, world)``); the volume is its own (cloned if shared)."""
        lv = self.user.world
        mother, index = "", -1
        model_lv = self.model.world
        for i in inst.path:
            _, child = self.user.daughter(lv, i)
            model_lv = self.model.logicals[model_lv].daughters[i].logical
            if child not in self.clones and self.counts[model_lv] > 1:
                base = f"{strip_pointer(child)}_u"
                n = 1
                while f"{base}{n}" in self.user.names:
                    n += 1
                clone = f"{base}{n}"
                self.user.clone(child, clone)
                self.clones.add(clone)
                d, _ = self.user.daughter(lv, i)
                r = _VOLUMEREF.search(d.group(0))
                assert r is not None
                new = d.group(0)[: r.start(1)] + clone + d.group(0)[r.end(1) :]
                self.user.replace_daughter(lv, i, new)
                self.counts[model_lv] -= 1
                child = clone
            mother, index, lv = lv, i, child
        return mother, index, lv


@dataclass
class Fragment:
    """score4's additions as Geant4 wrote them (a world of their own), renamed for the user's
    file."""

    defines: str
    materials: str
    solids: str
    volumes: str
    physvols: list[str]  # the mini world's daughters, in placement order
    names: dict[str, str]  # Geant4 name with pointer -> name in the export
    patches: dict[str, list[str]]  # target -> physvol names of its patch bodies


def read_fragment(
    path: Path, user: UserFile, user_materials: dict[str, str], patches: dict[str, set[str]]
) -> Fragment:
    """Parse the additions written by Geant4 (names with pointer suffixes) and rename them.

    ``user_materials`` maps a material's Geant4 name to its name in the user's file;
    ``patches`` the target of each rough layer to the Geant4 names of its patch logical volumes:
    their placements get copy number 0, and their names are returned in ``Fragment.patches``.
    """
    try:
        root = ET.parse(path).getroot()
    except ET.ParseError as err:  # Geant4's writer does not report a failed write (full disk)
        raise Score4Error(
            f"the GDML additions Geant4 wrote are incomplete or unreadable ({err}): is the disk "
            "full?"
        ) from None
    world_ref = root.find("setup/world")
    assert world_ref is not None
    world = world_ref.get("ref")
    taken: dict[str, set[str]] = {}  # per kind of name: the user's names, then ours
    serial: Counter[str] = Counter()
    names: dict[str, str] = {}
    keep_materials: list[ET.Element] = []
    materials = root.find("materials")
    mats = list(materials) if materials is not None else []
    for el in mats:  # materials the user's file has: referred to by its names
        n = el.get("name", "")
        if el.tag == "material":
            g4name = strip_pointer(n)
            if g4name in user_materials:
                names[n] = user_materials[g4name]
            elif g4name.startswith("G4_"):
                names[n] = g4name  # NIST: Geant4 and pyg4ometry know it by name
            else:
                keep_materials.append(el)
    if keep_materials:  # a material of score4's configuration: it and its elements, isotopes
        needed = {r.get("ref") for m in keep_materials for r in m.iter() if r.get("ref")}
        for el in mats:
            if el.tag in ("element", "isotope") and el.get("name") in needed:
                needed |= {r.get("ref") for r in el.iter() if r.get("ref")}
        keep_materials = [el for el in mats if el in keep_materials or el.get("name") in needed]

    def rename(n: str, kind: str) -> str:
        if n not in names:
            m = _POINTER.match(n)
            space = taken.setdefault(kind, set(user.names))
            names[n] = _unique(n if m is None else m.group(1) + m.group(2), space, serial)
        return names[n]

    def renamed(el: ET.Element, kind: str) -> None:
        inline = {id(c) for pv in el.iter("physvol") for c in pv if c.tag != "volumeref"}
        for e in el.iter():
            n = e.get("name")
            if n is not None and id(e) not in inline:  # inline transforms: after their physvol
                k = {"volume": "volume", "assembly": "volume", "physvol": "physvol"}
                rename(n, k.get(e.tag, kind))

    for section, kind in (("define", "define"), ("solids", "solid"), ("structure", "volume")):
        sec = root.find(section)
        if sec is not None:
            renamed(sec, kind)
    for m in keep_materials:
        renamed(m, "material")

    def sub(text: str) -> str:
        def one(m: re.Match) -> str:
            value = m.group(2)
            if value in names:
                return f'{m.group(1)}="{names[value]}"'
            p = _POINTER.match(value)
            if p is not None and p.group(2).startswith("_"):  # an inline transform: pv_pos
                owner = value[: len(value) - len(p.group(2))]
                if owner in names:
                    return f'{m.group(1)}="{names[owner]}{p.group(2)}"'
            return m.group(0)

        return re.sub(r"\b(name|ref|vertex[1-4]|solid)=\"([^\"]*)\"", one, text)

    def body(sec: ET.Element | None, skip: str | None = None) -> str:
        if sec is None:
            return ""
        parts = []
        for el in sec:
            if skip is not None and el.get("name") == skip:
                continue
            el.tail = None
            parts.append("    " + ET.tostring(el, encoding="unicode").strip() + "\n")
        return sub("".join(parts))

    structure = root.find("structure")
    assert structure is not None
    world_el = next(v for v in structure if v.get("name") == world)
    found: dict[str, list[str]] = {target: [] for target in patches}
    for pv in structure.iter("physvol"):
        ref = pv.find("volumeref")
        lv = strip_pointer(ref.get("ref", "")) if ref is not None else ""
        for target, lvs in patches.items():
            if lv in lvs:
                pv.attrib.pop("copynumber", None)
                found[target].append(names[pv.get("name", "")])
    physvols = []
    for pv in world_el.findall("physvol"):
        pv.tail = None
        physvols.append(sub(ET.tostring(pv, encoding="unicode").strip()))
    mat_sec = ET.Element("materials")
    mat_sec.extend(keep_materials)
    return Fragment(
        body(root.find("define")),
        body(mat_sec),
        body(root.find("solids")),
        body(structure, skip=world),
        physvols,
        names,
        found,
    )


def relink(text: str, source: Path, target: Path) -> str:
    """Point the file's includes (``<!ENTITY ... SYSTEM "f">``, ``<file name="f"/>``), written
    relative to folder ``source``, to the same files from folder ``target`` (relative paths where
    there is one)."""
    if source == target:
        return text
    import os

    def moved(name: str) -> str:
        if Path(name).is_absolute() or "://" in name:
            return name
        full = (source / name).resolve()
        try:
            return os.path.relpath(full, target)
        except ValueError:  # another drive
            return str(full)

    parts, at = [], 0
    for _, name, (start, end) in gdml_include_refs(text):
        parts += [text[at:start], moved(name)]
        at = end
    return "".join(parts) + text[at:]


def insert_section(text: str, tag: str, content: str, before: tuple[str, ...]) -> str:
    """Append ``content`` to the section ``tag`` of the file (made before the first section of
    ``before`` if the file has none)."""
    if not content:
        return text
    s = _section(text, tag)
    if s is None:
        at = min(i for i in (text.find(f"<{b}") for b in before) if i >= 0)
        return text[:at] + f"<{tag}>\n{content}  </{tag}>\n\n  " + text[at:]
    if s.empty:
        return text[: s.start] + f"<{tag}>\n{content}  </{tag}>" + text[s.end :]
    at = _line_start(text, s.end)
    return text[:at] + content + text[at:]


def register_patches(text: str, detectors: dict[str, list[str]]) -> tuple[str, list[str]]:
    """Add the patch physical volumes of each registered detector to its ``RMG_detector`` group.

    ``detectors`` maps the detector's physvol name (as in the file) to its patches' physvol
    names. Returns the text and the detectors found registered.
    """
    found = []
    for pv, patches in detectors.items():
        if not patches:
            continue
        m = re.search(
            rf"<auxiliary\b[^>]*?\bauxtype\s*=\s*\"{re.escape(pv)}\"[^>]*?"
            rf"\bauxvalue\s*=\s*\"([^\"]*)\"[^>]*?/>",
            text,
        )
        if m is None:
            continue
        group = text.rfind("<auxiliary", 0, m.start())
        if 'auxtype="RMG_detector"' not in text[group : m.start()].split(">", 1)[0]:
            continue
        parts = m.group(1).lstrip(":").split(",")
        uid = int(parts[0])
        table = parts[2] if len(parts) > 2 and parts[2] else strip_pointer(pv)
        indent = text[text.rfind("\n", 0, m.start()) + 1 : m.start()]
        lines = "".join(
            f'\n{indent}<auxiliary auxtype="{p}" auxvalue=":{uid},true,{table}"/>' for p in patches
        )
        text = text[: m.end()] + lines + text[m.end() :]
        found.append(pv)
    return text, found


def _mesh_key(mesh) -> bytes:
    """The triangles of ``mesh`` as a set (vertices rounded to 1e-12 mm, -0 as 0, each
    triangle's corners and the triangles in a fixed order): equal for meshes of the same
    triangles in any order."""
    tri = np.round(mesh.vertices[mesh.faces], 12) + 0.0
    order = np.lexsort(tri.transpose(2, 0, 1)[::-1], axis=-1)
    tri = np.take_along_axis(tri, order[:, :, None], axis=1).reshape(len(tri), 9)
    return tri[np.lexsort(tri.T[::-1])].tobytes()


def _layer_key(layer, mother_material, material) -> tuple:
    """What the volumes of a rough layer are made of: two layers of one target with the same key
    are the same volumes (placed twice), named after the first of them.

    The planes of a face of several planes (the sides of a G4Polyhedra's ``seg_<i>``, the planes
    of a mesh) never share: each plane's volumes carry its own name, as in a run, so a step in
    an exported patch says which plane it is on. A polygon face's envelope is its outline's
    prism, which is part of the key."""
    part = getattr(layer, "part", -1)
    prism = layer.envelope_prism()
    return (
        layer.name if part >= 0 else None,
        None if prism is None else _mesh_key(prism),
        tuple(layer.names),
        layer.base_thickness,
        layer.thickness,
        tuple(layer.patch_size),
        tuple(np.round(layer.frame.size, 12)),
        layer.cell_variants.shape,
        layer.cell_variants.tobytes(),
        layer.config.native_layout,
        layer.config.block_cells,
        getattr(layer, "ring", None),  # a round face's envelope
        tuple(layer.solid_kind(k) for k in range(len(layer.variants))),
        str(mother_material.GetName()),
        str(material.GetName()),
    )


def splice(g4, config, scene, out: Path, fragment_path: Path) -> dict:
    """Write the export of a GDML world (see the module docstring) to ``out``.

    Runs where Geant4 is imported (the additions are written by Geant4's writer to
    ``fragment_path`` first). Returns ``{"layers", "registered", "clones"}``.
    """
    from ..inputs.materials import find_material
    from ..world.scene import CurvedRoughLayer
    from .built import cut_for_layers, g4_solid
    from .curved import place_curved
    from .gdml import read_gdml
    from .gdml_world import _mother_frame, _target_in_mother
    from .tiling import _rotation, place_native

    model = scene.model
    src = Path(config.world.gdml)
    parser, world_pv = read_gdml(g4, src)

    def live(inst):
        pv = world_pv
        lv = pv.GetLogicalVolume()
        for i in inst.path:
            pv = lv.GetDaughter(i)
            lv = pv.GetLogicalVolume()
        return pv, lv

    big = 1e9  # mm: the additions' own world only carries them to the writer
    w_solid = g4.G4Box("score4_additions", big, big, big)
    w_lv = g4.G4LogicalVolume(w_solid, find_material(g4, "G4_Galactic"), "score4_additions")
    w_pv = g4.G4PVPlacement(
        None, g4.G4ThreeVector(), w_lv, "score4_additions", None, False, 0, False
    )
    keep: list = [parser, world_pv, w_solid, w_lv, w_pv]
    jobs: list[tuple] = []  # per daughter of the additions' world, in placement order
    patches: dict[str, set[str]] = {}
    for t in scene.targets:
        assert t.mother is not None
        if t.instance is None:
            material = find_material(
                g4, t.material, f"targets.{t.entry}.material", config.materials
            )
            solid, shift, kc = cut_for_layers(
                g4, scene, t, g4_solid(g4, t.described("targets"), t.name), t.name
            )
            lv = g4.G4LogicalVolume(solid, material, t.name)
            where = t.mother.to_local(t.translation) + shift
            pv = g4.G4PVPlacement(None, g4.G4ThreeVector(*where), lv, t.name, w_lv, False, 0, False)
            keep += [solid, kc, lv, pv]
            jobs.append(("box", t, None))
        else:
            _, t_lv = live(t.instance)
            material = t_lv.GetMaterial()
            if any(r.config.into for r in scene.layers_of(t.name)):
                if t_lv.GetNoDaughters():
                    raise ConfigError(
                        f"{t.name}: into: true cuts the volume, which holds daughters "
                        f"({t_lv.GetDaughter(0).GetName()}, ...); put the layer outside "
                        "(into: false)"
                    )
                solid, shift, kc = cut_for_layers(
                    g4, scene, t, t_lv.GetSolid(), f"{t_lv.GetName()}_cut"
                )
                lv = g4.G4LogicalVolume(solid, material, "score4_cut")
                pv = g4.G4PVPlacement(
                    None, g4.G4ThreeVector(), lv, "score4_cut", w_lv, False, 0, False
                )
                keep += [solid, kc, lv, pv]
                jobs.append(("cut", t, shift))
        _, m_lv = live(t.mother)
        envelopes: dict[tuple, object] = {}  # the target's layers of the same make: one volume
        for layer in scene.layers_of(t.name):
            if isinstance(layer, CurvedRoughLayer):  # bent patches in a shell, as a run builds
                # (placed as the layer's own target: on a boolean, the constituent it lies on)
                patch_lvs, k = place_curved(
                    g4, layer, w_lv, m_lv.GetMaterial(), material, _target_in_mother(layer.target)
                )
                keep.append(k)
                patches.setdefault(t.name, set()).update(str(lv.GetName()) for lv in patch_lvs)
                # one placement per piece of the envelope (a boolean's face cut by its parts)
                jobs += [("layer", t, layer)] * len(layer.envelope_views())
                continue
            frame = _mother_frame(layer.frame, t.mother)
            key = _layer_key(layer, m_lv.GetMaterial(), material)
            if key in envelopes:
                rot = _rotation(g4, frame.rotation)
                centre = frame.to_world(np.array([0.0, 0.0, layer.thickness / 2]))
                pv = g4.G4PVPlacement(
                    g4.G4Transform3D(rot, g4.G4ThreeVector(*centre)),
                    envelopes[key],
                    layer.name,
                    w_lv,
                    False,
                    0,
                    False,
                )
                keep += [rot, pv]
            else:
                patch_lvs, k = place_native(
                    g4, layer, w_lv, m_lv.GetMaterial(), material, frame=frame
                )
                keep.append(k)
                envelopes[key] = w_lv.GetDaughter(w_lv.GetNoDaughters() - 1).GetLogicalVolume()
                patches.setdefault(t.name, set()).update(str(lv.GetName()) for lv in patch_lvs)
            jobs.append(("layer", t, layer))
    writer = g4.G4GDMLParser()
    writer.SetAddPointerToName(True)
    writer.Write(str(fragment_path), w_pv, True)
    if not fragment_path.is_file():
        raise Score4Error(f"--gdml: Geant4 did not write the rough layers for {out}")

    text = relink(src.read_text(), src.resolve().parent, out.resolve().parent)
    user = UserFile.parse(text)
    walker = Walker(user, model)
    places: dict[str, tuple[str, int, str]] = {}  # target -> (mother, index, volume) in the file
    mothers: dict[str, str] = {}  # target -> the file's volume of its mother
    for t in scene.targets:  # the order of build_gdml_world: the same volumes are copied
        assert t.mother is not None
        if t.instance is not None:
            places[t.name] = walker.path(t.instance)
        if t.instance is None or scene.layers_of(t.name):
            mothers[t.name] = walker.path(t.mother)[2]
    materials = {
        strip_pointer(n): n for n in re.findall(r"<material\b[^>]*?\bname\s*=\s*\"([^\"]*)\"", text)
    }
    frag = read_fragment(fragment_path, user, materials, patches)
    volumes = frag.volumes
    for (kind, t, extra), physvol in zip(jobs, frag.physvols, strict=True):
        if kind in ("box", "layer"):
            user.add_daughters(mothers[t.name], f"      {physvol}\n")
            continue
        # cut: the target's volume takes the cut solid, its placement the shifted position
        cut_lv = _VOLUMEREF.search(physvol)
        assert cut_lv is not None
        m = re.search(
            rf"<volume name=\"{re.escape(cut_lv.group(1))}\">.*?</volume>\s*", volumes, re.DOTALL
        )
        assert m is not None
        solid_ref = re.search(r"<solidref ref=\"([^\"]*)\"", m.group(0))
        assert solid_ref is not None
        volumes = volumes[: m.start()] + volumes[m.end() :]
        mother, i, vol = places[t.name]
        at = user.index(vol)
        v = user.items[at][2]
        old = re.search(r"<solidref\b[^>]*?\bref\s*=\s*\"([^\"]*)", v)
        assert old is not None
        user.items[at][2] = v[: old.start(1)] + solid_ref.group(1) + v[old.end(1) :]
        placement = model.logicals[t.mother.logical].daughters[t.instance.path[-1]]
        moved = placement.translation + placement.rotation @ extra
        d, _ = user.daughter(mother, i)
        pv_text = re.sub(r"\s*<position(?:ref)?\b[^>]*/>", "", d.group(0), count=1)
        name = _NAME.search(pv_text)
        assert name is not None
        pos = (
            f'<position name="{name.group(1)}_cut_pos" unit="mm" x="{float(moved[0])!r}" '
            f'y="{float(moved[1])!r}" z="{float(moved[2])!r}"/>'
        )
        ref = _VOLUMEREF.search(pv_text)
        assert ref is not None
        end = pv_text.index(">", ref.end()) + 1
        user.replace_daughter(mother, i, pv_text[:end] + "\n        " + pos + pv_text[end:])
    user.items.insert(0, ["text", "", "\n" + volumes])
    text = user.text()
    text = insert_section(text, "define", frag.defines, ("materials", "solids", "structure"))
    text = insert_section(text, "materials", frag.materials, ("solids", "structure"))
    text = insert_section(text, "solids", frag.solids, ("structure",))
    detectors = {}
    for target, pvs in frag.patches.items():
        if target in places:
            mother, i, _ = places[target]
            name = _NAME.search(user.daughter(mother, i)[0].group(0))
            assert name is not None
            detectors[name.group(1)] = pvs
    text, registered = register_patches(text, detectors)
    out.write_text(text)
    return {
        "layers": [layer.name for layer in scene.layers],
        "registered": registered,
        "clones": sorted(walker.clones),
    }
