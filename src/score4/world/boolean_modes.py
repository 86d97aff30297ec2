"""What a rough layer on a boolean solid's face takes besides its geometry (numpy, no Geant4):
``tiling``, ``native_layout`` and ``into``, checked by :mod:`score4.world.boolean_layers`.

* ``tiling: portal`` cannot work on a boolean's face, for two reasons: a portal's subworlds must
  lie where no particle goes, which score4 knows only in the world it generates, whose targets
  are boxes of the configuration (a boolean solid comes from a GDML world); and a portal jumps
  into a variant's subworld from every cell, while a boolean's face keeps patches only on the
  cells proven on its surface (the others stay flat).
* ``native_layout: replicas`` repeats one cell box over the whole rectangle of cells: it works
  where every cell of a flat face holds its patch (a face the other solids do not cut, such as
  the side of a box less a tube along its axis), and is refused, with the count of cells off the
  surface, where they do not.
* ``into: true`` would cut the boolean's constituent below the face inside the Geant4 boolean
  solid read from the GDML file, which score4 does not rebuild: refused.
"""

from __future__ import annotations

from ..errors import ConfigError
from ..inputs.config import RoughFace
from .scene import CurvedRoughLayer, PolygonRoughLayer, RingRoughLayer, RoughLayer


def check_modes(rough: RoughFace, where: str, what: str, leaf_kind: str, face: str) -> None:
    """One-line errors for ``into: true`` and ``tiling: portal`` on a boolean's face ``what``
    (face ``face`` of its constituent, a ``leaf_kind``)."""
    if rough.into:
        raise ConfigError(
            f"{where}: into: true on {what} would cut its {leaf_kind} below face {face} inside "
            "the boolean solid read from the GDML file, which score4 does not rebuild; put the "
            "layer outside the volume (into: false)"
        )
    if rough.tiling == "portal":
        raise ConfigError(
            f"{where}: tiling portal on {what}: a portal's subworlds must lie where no particle "
            "goes, which score4 knows only in the world it generates, whose targets are boxes "
            "(a boolean solid comes from a GDML world), and it jumps into a patch from every "
            "cell, while a boolean's face keeps patches only where it lies on the solid's "
            "surface; take tiling: native"
        )


def check_replicas(layer: RoughLayer, where: str, what: str) -> None:
    """``native_layout: replicas`` on a boolean's face: every cell of a flat rectangle holds its
    patch, or a one-line error (call once the kept cells are known)."""
    if layer.config.native_layout != "replicas":
        return
    if isinstance(layer, CurvedRoughLayer | PolygonRoughLayer | RingRoughLayer):
        return  # refused on the constituent's face already (a rectangle only)
    mask = layer.mask
    if mask is None:
        return
    off = int(mask.size - mask.sum())
    if off:
        raise ConfigError(
            f"{where}: native_layout replicas fills every cell; {off} of the {mask.size} cells of "
            f"{what} lie off the solid's surface (or are not proven on it) and hold no patch: "
            "take auto, nested or placements"
        )
