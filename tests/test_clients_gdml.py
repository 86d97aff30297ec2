"""pyg4ometry (the Python GDML toolkit Geant4 users run) reads every GDML file score4 writes.

``score4 surface export --gdml`` writes with Geant4's own G4GDMLParser (the only GDML writer in
score4); pyg4ometry 1.4.6 refused those files before score4 removed the ``<T>``/``<P>`` Geant4
puts on NIST materials. The files are read here with pyg4ometry and compared with score4's own
mesh: facet count and volume for tessellated bodies, node count and volume for multi-unions.

pyg4ometry meshes a G4Trd whose top is a point (a pyramid) into 2 polygons with half the
volume (pyg4ometry 1.4.6, measured: 1.333e-7 instead of 2.667e-7 mm^3 for a 10 x 10 x 8 um
pyramid), so the multi-union volume is computed from the node parameters pyg4ometry read
(the prismatoid formula, exact for a G4Trd), not from its mesh. pyg4ometry also meshes every
logical volume while reading; for a multi-union of bump frusta that CSG union did not finish in
2 minutes (6 spikes; measured), so the files are read with ``pyg4ometry.config.doMeshing`` off
and tessellated solids are meshed explicitly.
"""

from __future__ import annotations

import pytest
import yaml

from score4.cli.main import main
from score4.geometry.gdml import drop_nist_state
from score4.surface.store import load_surface
from score4.surface.triangle_mesh import signed_volume

pyg4ometry = pytest.importorskip("pyg4ometry")

UM = 1e-3  # mm
SURFACES = {
    "pyramids": {
        "kind": "spikes",
        "nx": 4,
        "ny": 3,
        "width_x": "10 um",
        "width_y": "15 um",
        "height": "8 um",
        "height_sigma": "2 um",
        "seed": 2,
    },
    "bumps": {"kind": "spikes", "nx": 3, "ny": 2, "width": "10 um", "height": "6 um"},
    "random": {
        "kind": "random",
        "nx": 16,
        "ny": 12,
        "pitch": "1 um",
        "sq": "0.5 um",
        "corr_length": "2 um",
        "seed": 1,
    },
}
SURFACES["bumps"].update(shape="bump", n_layers=3)


@pytest.fixture(autouse=True)
def _no_meshing_on_read(monkeypatch):
    monkeypatch.setattr(pyg4ometry.config, "doMeshing", False)


def _export(tmp_path, name: str, solid: str, material: str = "G4_Si"):
    spec = tmp_path / f"{name}.yaml"
    spec.write_text(yaml.safe_dump(SURFACES[name]))
    surface_file = tmp_path / f"{name}.s4s.h5"
    assert main(["surface", "generate", str(spec), "--out", str(surface_file)]) == 0
    gdml = tmp_path / f"{name}_{solid}.gdml"
    args = ["surface", "export", str(surface_file), "--gdml", str(gdml), "--solid", solid]
    args += ["--base-thickness", "2 um", "--material", material]
    assert main(args) == 0  # Geant4 writes it in a process of its own (sim.export_surface)
    return load_surface(surface_file), gdml


def _read(gdml):
    registry = pyg4ometry.gdml.Reader(str(gdml)).getRegistry()
    world = registry.getWorldVolume()
    (placement,) = world.daughterVolumes
    return placement.logicalVolume


def _trd_volume(trd) -> float:
    x1, x2, y1, y2, z = (float(getattr(trd, k)) for k in ("pX1", "pX2", "pY1", "pY2", "pZ"))
    middle = (x1 + x2) / 2 * (y1 + y2) / 2
    return z / 6 * (x1 * y1 + x2 * y2 + 4 * middle)


@pytest.mark.parametrize("name", ["pyramids", "random"])
def test_pyg4ometry_reads_tessellated_export(tmp_path, name):
    surface, gdml = _export(tmp_path, name, "tessellated")
    body = surface.body(2 * UM)
    lv = _read(gdml)
    assert lv.material.name == "G4_Si"
    assert type(lv.solid).__name__ == "TessellatedSolid"
    assert len(lv.solid.meshtess) == body.n_faces
    ours = signed_volume(body)
    assert lv.solid.mesh().volume() == pytest.approx(ours, rel=1e-9)


@pytest.mark.parametrize("name", ["pyramids", "bumps"])
def test_pyg4ometry_reads_multiunion_export(tmp_path, name):
    surface, gdml = _export(tmp_path, name, "multiunion", material="G4_Cu")
    lv = _read(gdml)
    assert lv.material.name == "G4_Cu"
    union = lv.solid
    assert type(union).__name__ == "MultiUnion"
    base, *spikes = union.objects
    assert len(spikes) == len(surface.spikes.frustums())
    box = float(base.pX) * float(base.pY) * float(base.pZ)
    # nodes do not overlap (spikes stand on the base, layers stack): volumes add up
    volume = box + sum(_trd_volume(t) for t in spikes)
    assert volume == pytest.approx(signed_volume(surface.body(2 * UM)), rel=1e-9)


def test_nist_state_is_dropped_only_from_nist_materials():
    text = (
        '<material name="G4_Si" state="solid">\n  <T unit="K" value="293.15"/>\n'
        '  <D unit="g/cm3" value="2.33"/>\n</material>\n'
        '<material name="Mine" state="gas">\n  <T unit="K" value="80"/>\n'
        '  <P unit="pascal" value="2"/>\n</material>\n'
    )
    out = drop_nist_state(text)
    assert '<T unit="K" value="293.15"/>' not in out
    assert '<D unit="g/cm3" value="2.33"/>' in out
    assert '<T unit="K" value="80"/>' in out
    assert '<P unit="pascal" value="2"/>' in out
