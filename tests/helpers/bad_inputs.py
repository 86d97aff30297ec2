"""The bad inputs of the "Why" lists of issues 20 and 26, one case each (tests/test_bad_inputs.py).

Each case writes its files into an empty folder and gives the command line; it says which
class of fault the input caused when the issue was filed (crash, traceback, silent accept,
footgun, refused) and the words the one-line error must hold now.

Run as a script it classifies every case as a user meets it, each command in its own process
(with a timeout), and prints the counts per class; run it from tests/ (it reads conftest's base
config) against any checkout with ``PYTHONPATH=<checkout>/src``:

    cd tests && ../.venv/bin/python -m helpers.bad_inputs    # this checkout
"""

from __future__ import annotations

import copy
import hashlib
import json
import os
import subprocess
import sys
import tempfile
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import h5py
import numpy as np
import yaml

from conftest import BASE_CONFIG

# conftest's BASE_CONFIG, with two overrides: the cases run 20 events (not 100), and their
# source leaves the direction to its default.
BASE = copy.deepcopy(BASE_CONFIG)
BASE["run"] = {**BASE["run"], "events": 20}
del BASE["source"]["direction"]
PYRAMIDS = {"kind": "spikes", "nx": 2, "ny": 2, "width": "5 um", "height": "2 um"}


def config(**changes) -> dict:
    """BASE with sections updated (a ``source`` with ``vertices`` replaces it);
    ``targets.0.<key>`` updates the first target."""
    data = copy.deepcopy(BASE)
    if "vertices" in changes.get("source", {}):
        data["source"] = {}
    for key, value in changes.items():
        if key.startswith("targets.0."):
            data["targets"][0][key.removeprefix("targets.0.")] = value
        elif isinstance(value, dict) and isinstance(data.get(key), dict):
            data[key] = {**data[key], **value}
        else:
            data[key] = value
    return data


def rough(spec: dict, **face) -> dict:
    """A config whose crystal (20 um x 10 um top) has a rough +z face of surface ``spec``."""
    face = {"surface": "s", **face}
    return config(
        surfaces={"s": spec},
        **{"targets.0.size": ["20 um", "10 um", "1 mm"], "targets.0.rough": [face]},
    )


def vertex_file(path: Path, x: float = 0.0, units: str = "mm", unequal: bool = False) -> None:
    """A two-event vertex file in score4's layout (h5py only, as another program writes it)."""
    n = 2
    with h5py.File(path, "w") as f:
        f.attrs["format"] = "score4-vertices"
        f.attrs["format_version"] = 1
        f.attrs["config"] = "{}"
        f.attrs["seed"] = 1
        f.attrs["n_events"] = n
        g = f.create_group("vertices")
        columns = {
            "event": np.arange(n),
            "particle": np.array([b"alpha"] * n),
            "energy": np.full(n, 5.3),
            "xloc": np.full(n, x),
            "yloc": np.zeros(n if not unequal else n + 1),
            "zloc": np.full(n, 1e-9),
            "dirx": np.zeros(n),
            "diry": np.zeros(n),
            "dirz": np.full(n, -1.0),
        }
        for name, data in columns.items():
            d = g.create_dataset(name, data=data)
            if name in ("xloc", "yloc", "zloc"):
                d.attrs["units"] = units


def text_grid(path: Path, header: str = "# pitch: 1 um\n# z_unit: nm\n", bad: str = "") -> None:
    rows = [[str(10.0 * ((i * j) % 3)) for i in range(5)] for j in range(5)]
    if bad:
        rows[2][2] = bad
    path.write_text(header + "\n".join(" ".join(r) for r in rows) + "\n")


def results_file(path: Path) -> None:
    """A small results file, made with score4's own writer (no Geant4 run)."""
    from score4.runner.output import merge_chunks, write_chunk
    from score4.source.primaries import Primaries

    n = 4
    p = Primaries(
        event=np.arange(n),
        particle=np.array(["alpha"] * n),
        energy=np.full(n, 5.3),
        position=np.zeros((n, 3)),
        direction=np.tile([0.0, 0.0, -1.0], (n, 1)),
        extra={},
    )
    chunk = path.with_name("chunk.h5")
    write_chunk(chunk, 0, ["crystal"], {"edep": np.full((n, 1), 5.3)}, p)
    merge_chunks([chunk], path, {"seed": 1, "n_events": n, "physics_mode": "lite"})
    chunk.unlink()


def _alias_bomb() -> str:
    """1 kB of YAML whose value physics.mode expands to 10^9 items ("billion laughs")."""
    lists = ["&a [x, x, x, x, x, x, x, x, x, x]"]
    for prev, name in zip("abcdefgh", "bcdefghi", strict=True):
        lists.append(f"&{name} [" + ", ".join([f"*{prev}"] * 10) + "]")
    return "physics:\n  mode: [" + ", ".join(lists) + "]\n"


# --- issue 26 ---------------------------------------------------------------------------------

#: A GDML world (its materials in an XML entity file, mat.xml) with a silicon crystal and a copper
#: plate below it; ``plate_z`` -11 mm makes them overlap by 1 mm, -13 mm makes them touch.
_GDML = """<?xml version="1.0" encoding="UTF-8"?>
<!DOCTYPE gdml [
<!ENTITY materials SYSTEM "mat.xml">
]>
<gdml>
  <define/>
  &materials;
  <solids>
    <box name="WorldBox" x="200" y="200" z="200" lunit="mm"/>
    <box name="CrystalBox" x="20" y="20" z="20" lunit="mm"/>
    <box name="PlateBox" x="20" y="20" z="4" lunit="mm"/>
  </solids>
  <structure>
    <volume name="Crystal"><materialref ref="G4_Si"/><solidref ref="CrystalBox"/></volume>
    <volume name="Plate"><materialref ref="G4_Cu"/><solidref ref="PlateBox"/></volume>
    <volume name="World">
      <materialref ref="G4_Galactic"/><solidref ref="WorldBox"/>
      <physvol name="crystal_pv"><volumeref ref="Crystal"/></physvol>
      <physvol name="plate_pv">
        <volumeref ref="Plate"/><position name="p" x="0" y="0" z="PLATE_Z" unit="mm"/>
      </physvol>
    </volume>
  </structure>
  <setup name="Default" version="1.0"><world ref="World"/></setup>
</gdml>
"""


def gdml_world(path: Path, plate_z: float = -13.0) -> None:
    """The GDML world above at ``path``, with its entity file mat.xml beside it."""
    path.write_text(_GDML.replace("PLATE_Z", f"{plate_z:g}"))
    (path.parent / "mat.xml").write_text("<materials/>\n")


def gdml_config(**world) -> dict:
    """A run of alphas from the top face of the GDML world's crystal (gdml_world)."""
    return {
        "physics": "lite",
        "world": {"gdml": "w.gdml", **world},
        "targets": [{"volume": "crystal_pv"}],
        "source": {
            "particle": "alpha",
            "energy": "5.3 MeV",
            "surface": {"volume": "crystal_pv", "face": "+z"},
        },
        "run": {"events": 20, "seed": 7},
    }


def symlink_to(target: str) -> Callable[[Path], None]:
    return lambda path: path.symlink_to(target)


_REAL_RUN: dict[str, Path] = {}


def real_run(path: Path) -> None:
    """Results of a real (small) score4 run of BASE: 200 alphas from the crystal's top face,
    made once per process and copied."""
    import shutil

    if "r" not in _REAL_RUN:
        from score4.cli.main import main as score4_main

        folder = Path(tempfile.mkdtemp(prefix="score4-bad-inputs-"))
        (folder / "c.yaml").write_text(yaml.safe_dump(config(run={"events": 200, "seed": 3})))
        out = folder / "r.h5"
        assert score4_main(["-q", "run", str(folder / "c.yaml"), "--out", str(out)]) == 0
        _REAL_RUN["r"] = out
    shutil.copyfile(_REAL_RUN["r"], path)


def templates_file(path: Path, zero: bool = False) -> None:
    """score4 template of :func:`real_run` (1 mBq/cm2, 0 to 6 MeV in 60 bins) at ``path``;
    ``zero``: every rate and count set to 0 (a source none of whose events reach the detector)."""
    from score4.cli.main import main as score4_main

    run = path.with_name(path.stem + "_run.h5")
    real_run(run)
    argv = ["-q", "template", str(run), "--activity", "1 mBq/cm2", "--emax", "6 MeV"]
    assert score4_main([*argv, "--bins", "60", "--out", str(path)]) == 0
    run.unlink()
    if zero:
        with h5py.File(path, "r+") as f:

            def clear(name: str, obj: object) -> None:
                if (
                    isinstance(obj, h5py.Dataset)
                    and "edges" not in name
                    and "binedge" not in name
                    and obj.dtype.kind == "f"
                    and obj.ndim >= 1
                    and obj.shape[0] == 60
                ):
                    obj[...] = 0.0

            f.visititems(clear)


def data_csv(path: Path, counts_at_kev: float = 50.0, counts: float = 1e9) -> None:
    """A measured spectrum on the templates' bins (0-6 MeV in 60 bins): ``counts`` in the bin of
    ``counts_at_kev``, none elsewhere."""
    lines = ["bin_low_keV,bin_high_keV,counts"]
    for k in range(60):
        lo, hi = 100.0 * k, 100.0 * (k + 1)
        lines.append(f"{lo:g},{hi:g},{counts if lo <= counts_at_kev < hi else 0:g}")
    path.write_text("\n".join(lines) + "\n")


MODEL_TWO = {
    "detector": "crystal",
    "livetime": "1 yr",
    "components": [
        {"name": "top", "template": "t.h5", "activity": "1 mBq/cm2"},
        {"name": "far", "template": "t0.h5", "activity": "1 mBq/cm2"},
    ],
}
MODEL_ONE = {**MODEL_TWO, "components": MODEL_TWO["components"][:1]}
TEMPLATE = ["template", "r.h5", "--activity", "1 mBq/cm2", "--out", "t.h5"]


@dataclass
class Case:
    """One bad input: files to write, the command, what it did before, what it must say now."""

    id: str
    cls: str  # crash | traceback | silent | footgun | other (its fault when the issue was filed)
    argv: list[str]
    files: dict[str, object] = field(default_factory=dict)  # name -> dict (YAML) | str | writer
    expect: str = ""  # words of the one-line error; "" for an input that must now be accepted
    subprocess: bool = False  # run in its own process (Geant4 in the command, or a hang)
    inputs: tuple[str, ...] = ()  # files that must stay unchanged (default: every file written)
    outputs: tuple[str, ...] = ()  # files that must not appear (on an error)

    def write(self, folder: Path) -> None:
        for name, content in self.files.items():
            path = folder / name
            if callable(content):
                content(path)
            elif isinstance(content, dict):
                path.write_text(yaml.safe_dump(content))
            else:
                path.write_text(str(content))


def _writer(fn: Callable, **kwargs) -> Callable[[Path], None]:
    return lambda path: fn(path, **kwargs)


RUN = ["run", "c.yaml", "--out", "r.h5"]
VERT = ["vertices", "c.yaml", "--out", "v.h5"]
GEN = ["surface", "generate", "s.yaml", "--out", "s.s4s.h5"]
TILES_2 = {"variants": [{"surface": "s", "density": 0.5}, {"surface": "s", "density": 0.5}]}

CASES: list[Case] = [
    # --- crashes ---------------------------------------------------------------------------
    Case(
        "length-2pm-target",
        "crash",
        RUN,
        {"c.yaml": config(**{"targets.0.size": ["2 pm", "1 cm", "1 cm"]})},
        "targets.0.size.0: '2 pm' is shorter than 10 pm",
        outputs=("r.h5",),
    ),
    Case(
        "length-3pm-base",
        "crash",
        RUN,
        {"c.yaml": rough(PYRAMIDS, base_thickness="3 pm")},
        "base_thickness: '3 pm' is shorter than 10 pm",
        outputs=("r.h5",),
    ),
    Case(
        "length-4pm-target",
        "crash",
        RUN,
        {"c.yaml": config(**{"targets.0.size": ["1 cm", "1 cm", "4 pm"]})},
        "targets.0.size.2: '4 pm' is shorter than 10 pm",
        outputs=("r.h5",),
    ),
    Case(
        "range-thickness-2pm",
        "crash",
        ["range", "alpha", "5 MeV", "G4_Si", "--thickness", "2 pm", "--events", "5"],
        expect="--thickness",
        subprocess=True,
    ),
    Case(
        "vertex-file-x-1000mm",
        "crash",
        RUN,
        {
            "v.h5": _writer(vertex_file, x=1000.0),
            "c.yaml": config(source={"vertices": "v.h5"}, run={"events": 2}),
        },
        "lies outside the world",
        outputs=("r.h5",),
    ),
    Case(
        "confine-false-50mm-depth",
        "crash",
        RUN,
        {
            "c.yaml": config(
                source={"confine": False, "depth": {"profile": "uniform", "max": "50 mm"}},
                run={"events": 200},
            )
        },
        "lies outside the world",
        outputs=("r.h5",),
    ),
    Case(
        "yaml-alias-bomb",
        "crash",
        RUN,
        {"c.yaml": _alias_bomb()},
        "expands to more than",
        subprocess=True,
    ),
    # --- tracebacks ------------------------------------------------------------------------
    Case(
        "spikes-1e5-squared",
        "traceback",
        GEN,
        {"s.yaml": {**PYRAMIDS, "nx": 100000, "ny": 100000}},
        "needs about",
        outputs=("s.s4s.h5",),
    ),
    Case(
        "random-1e5-squared",
        "traceback",
        GEN,
        {
            "s.yaml": {
                "kind": "random",
                "nx": 100000,
                "ny": 100000,
                "pitch": "1 um",
                "sq": "1 um",
                "corr_length": "5 um",
            }
        },
        "needs about",
        outputs=("s.s4s.h5",),
    ),
    Case(
        "n_tiles-1e12",
        "traceback",
        VERT,
        {"c.yaml": rough(PYRAMIDS, **TILES_2, surface=None, fill="tiles", n_tiles=1.0e12)},
        "n_tiles",
        outputs=("v.h5",),
    ),
    Case(
        "resample-pitch-1nm",
        "traceback",
        GEN,
        {
            "g.txt": _writer(text_grid, header="# pitch: 100 um\n# z_unit: nm\n"),
            "s.yaml": {"kind": "measured", "file": "g.txt", "resample_pitch": "1 nm"},
        },
        "resample_pitch",
        outputs=("s.s4s.h5",),
    ),
    Case(
        "vertex-columns-unequal",
        "traceback",
        RUN,
        {
            "v.h5": _writer(vertex_file, unequal=True),
            "c.yaml": config(source={"vertices": "v.h5"}, run={"events": 2}),
        },
        "all columns must be equally long",
        outputs=("r.h5",),
    ),
    Case(
        "yaml-nesting-5000",
        "traceback",
        RUN,
        {"c.yaml": "a: " + "[" * 5000 + "]" * 5000 + "\n"},
        "nested deeper than",
        subprocess=True,
    ),
    # --- silent accepts --------------------------------------------------------------------
    Case(
        "n_tiles-without-tiles",
        "silent",
        VERT,
        {"c.yaml": rough(PYRAMIDS, n_tiles=8)},
        "n_tiles: used only with fill: tiles",
        outputs=("v.h5",),
    ),
    Case(
        "block_cells-with-multiunion",
        "silent",
        VERT,
        {"c.yaml": rough(PYRAMIDS, solid="multiunion", block_cells=1)},
        "block_cells: used only with solid: blocks",
        outputs=("v.h5",),
    ),
    Case(
        "block_cells-auto-on-spikes",
        "silent",
        VERT,
        {"c.yaml": rough(PYRAMIDS, block_cells=1)},
        "block_cells: used only with solid: blocks (here solid auto is multiunion)",
        outputs=("v.h5",),
    ),
    Case(
        "native_layout-with-portal",
        "silent",
        VERT,
        {"c.yaml": rough(PYRAMIDS, tiling="portal", native_layout="placements")},
        "native_layout: used only with tiling: native",
        outputs=("v.h5",),
    ),
    Case(
        "trim_max_energy-with-geant4",
        "silent",
        VERT,
        {"c.yaml": config(physics={"heavy_ions": "geant4", "trim_max_energy": "2 MeV"})},
        "trim_max_energy: used only with heavy_ions: trim",
        outputs=("v.h5",),
    ),
    Case(
        "trim_histories-with-geant4",
        "silent",
        VERT,
        {"c.yaml": config(physics={"heavy_ions": "geant4", "trim_histories": 500})},
        "trim_histories: used only with heavy_ions: trim or alphas: trim",
        outputs=("v.h5",),
    ),
    Case(
        "trim_histories-too-few",
        "silent",
        VERT,
        {"c.yaml": config(physics={"trim_histories": 5})},
        "physics.trim_histories: Input should be greater than or equal to 10 (got 5)",
        outputs=("v.h5",),
    ),
    Case(
        "formula-Te0O2",
        "silent",
        VERT,
        {
            "c.yaml": config(
                materials={"TeO": {"formula": "Te0O2", "density": "6 g/cm3"}},
                **{"targets.0.material": "TeO"},
            )
        },
        "the count of Te must be a number > 0",
        outputs=("v.h5",),
    ),
    *(
        Case(
            f"density-{d.split()[0]}",
            "silent",
            VERT,
            {
                "c.yaml": config(
                    materials={"X": {"formula": "TeO2", "density": d}},
                    **{"targets.0.material": "X"},
                )
            },
            "is outside 1e-12 ... 30 g/cm3",
            outputs=("v.h5",),
        )
        for d in ("1e30 g/cm3", "1000 g/cm3", "1e-30 g/cm3")
    ),
    Case(
        "vertex-file-nan",
        "silent",
        RUN,
        {
            "v.h5": _writer(vertex_file, x=float("nan")),
            "c.yaml": config(source={"vertices": "v.h5"}, run={"events": 2}),
        },
        "every value must be a finite number",
        outputs=("r.h5",),
    ),
    Case(
        "text-grid-inf",
        "silent",
        GEN,
        {"g.txt": _writer(text_grid, bad="inf"), "s.yaml": {"kind": "measured", "file": "g.txt"}},
        "heights must be finite",
        outputs=("s.s4s.h5",),
    ),
    Case(
        "text-grid-pitch-1km",
        "silent",
        GEN,
        {
            "g.txt": _writer(text_grid, header="# pitch: 1 km\n# z_unit: nm\n"),
            "s.yaml": {"kind": "measured", "file": "g.txt"},
        },
        "longer than 100 m",
        outputs=("s.s4s.h5",),
    ),
    Case(
        "tiles-fewer-than-variants",
        "silent",
        VERT,
        {"c.yaml": rough(PYRAMIDS, **TILES_2, surface=None, fill="tiles", n_tiles=1)},
        "gets none of them",
        outputs=("v.h5",),
    ),
    Case(
        "vertex-file-units-m",
        "silent",
        RUN,
        {
            "v.h5": _writer(vertex_file, x=0.02, units="m"),  # 20 mm: outside the world
            "c.yaml": config(source={"vertices": "v.h5"}, run={"events": 2}),
        },
        "(20, 0, 1e-06) mm lies outside the world",
        outputs=("r.h5",),
    ),
    Case(
        "vertices-unknown-material",
        "silent",
        VERT,
        {"c.yaml": config(**{"targets.0.material": "G4_SILICN"})},
        "targets.0.material: unknown material 'G4_SILICN'",
        outputs=("v.h5",),
    ),
    Case(
        "events-1e20",
        "silent",
        [*RUN, "--events", "1e20"],
        {"c.yaml": config()},
        "more than score4's limit of 1e12",
        outputs=("r.h5",),
    ),
    # --- footguns --------------------------------------------------------------------------
    Case(
        "vertices-out-is-config",
        "footgun",
        ["vertices", "c.yaml", "--out", "c.yaml", "--overwrite"],
        {"c.yaml": config()},
        "--out: 'c.yaml' is the configuration",
    ),
    Case(
        "run-out-is-replayed-vertex-file",
        "footgun",
        ["run", "c.yaml", "--out", "v.h5", "--overwrite"],
        {
            "v.h5": _writer(vertex_file),
            "c.yaml": config(source={"vertices": "v.h5"}, run={"events": 2}),
        },
        "is the file of source.vertices",
    ),
    Case(
        "export-csv-is-results",
        "footgun",
        ["export", "r.h5", "--csv", "r.h5", "--overwrite"],
        {"r.h5": results_file},
        "is the results file",
    ),
    # --- issue 26: outputs that destroy inputs -------------------------------------------------
    Case(
        "export-gdml-is-the-world",
        "footgun",
        ["geometry", "export", "c.yaml", "--gdml", "w.gdml", "--overwrite"],
        {"w.gdml": gdml_world, "c.yaml": gdml_config()},
        "--gdml: 'w.gdml' is the file of world.gdml",
    ),
    Case(
        "export-gdml-is-the-config",
        "footgun",
        ["geometry", "export", "c.yaml", "--gdml", "c.yaml", "--overwrite"],
        {"w.gdml": gdml_world, "c.yaml": gdml_config()},
        "--gdml: 'c.yaml' is the configuration",
    ),
    Case(
        "export-gdml-is-an-include",
        "footgun",
        ["geometry", "export", "c.yaml", "--gdml", "mat.xml", "--overwrite"],
        {"w.gdml": gdml_world, "c.yaml": gdml_config()},
        "included by the file of world.gdml",
    ),
    Case(
        "export-gdml-is-a-link-to-the-world",
        "footgun",
        ["geometry", "export", "c.yaml", "--gdml", "l.gdml", "--overwrite"],
        {"w.gdml": gdml_world, "l.gdml": symlink_to("w.gdml"), "c.yaml": gdml_config()},
        "--gdml: 'l.gdml' is the file of world.gdml",
    ),
    Case(
        "template-out-is-the-results",
        "footgun",
        ["template", "r.h5", "--activity", "1 mBq/cm2", "--out", "r.h5", "--overwrite"],
        {"r.h5": results_file},
        "--out: 'r.h5' is the run results",
    ),
    Case(
        "template-root-is-the-out",
        "footgun",
        [*TEMPLATE, "--root", "t.h5"],
        {"r.h5": results_file},
        "--root: 't.h5' is also the output of --out",
    ),
    Case(
        "template-plot-xyz-before-anything",
        "footgun",
        [*TEMPLATE, "--plot", "t.xyz"],
        {"r.h5": results_file},
        "--plot: unknown image format '.xyz'",
    ),
    Case(
        "plot-out-is-its-input",
        "footgun",
        ["plot", "r.h5", "--out", "r.h5", "--overwrite"],
        {"r.h5": results_file},
        "--out: 'r.h5' is input r.h5",
    ),
    Case(
        "model-pseudo-data-is-the-model",
        "footgun",
        ["model", "m.yaml", "--pseudo-data", "t.h5", "--overwrite"],
        {"t.h5": results_file, "m.yaml": MODEL_ONE},  # refused before any template is read
        "is the file of components.0.template",
    ),
    Case(
        "run-log-is-the-config",
        "footgun",
        ["run", "r.geant4.log", "--out", "r.h5"],
        {"r.geant4.log": config()},
        "its Geant4 log: 'r.geant4.log' is the configuration",
    ),
    # --- issue 26: memory ------------------------------------------------------------------------
    Case(
        "template-bins-1e8",
        "crash",
        [*TEMPLATE, "--bins", "100000000"],
        {"r.h5": real_run},
        "100000000 bins are more than score4's limit of 1000000",
    ),
    Case(
        "plot-bins-1e8",
        "traceback",
        ["plot", "r.h5", "--out", "p.png", "--bins", "100000000"],
        {"r.h5": results_file},
        "100000000 bins are more than score4's limit of 1000000",
    ),
    Case(
        "run-jobs-1e5",
        "other",
        [*RUN, "--jobs", "100000"],
        {"c.yaml": config()},
        "--jobs: running 100000 Geant4 processes (at least 150 MB each) needs about",
    ),
    Case(
        "config-histogram-bins-1e8",
        "other",
        RUN,
        {"c.yaml": config(output={"histogram": {"bins": 100_000_000}})},
        "output.histogram.bins",
    ),
    # --- issue 26: tracebacks --------------------------------------------------------------------
    Case(
        "out-name-300-characters",
        "traceback",
        ["vertices", "c.yaml", "--out", "v" * 297 + ".h5"],
        {"c.yaml": config()},
        "choose a shorter name",
    ),
    Case(
        "model-component-template-all-zero",
        "traceback",
        ["model", "m.yaml", "--data", "d.csv"],
        {
            "t.h5": templates_file,
            "t0.h5": _writer(templates_file, zero=True),
            "d.csv": _writer(data_csv, counts_at_kev=5250.0, counts=10),
            "m.yaml": MODEL_TWO,
        },
        "components.1 (far): its template is zero in every bin of the fit range",
    ),
    Case(
        "model-counts-where-every-template-is-zero",
        "silent",
        ["model", "m.yaml", "--data", "d.csv"],
        {
            "t.h5": templates_file,
            "d.csv": _writer(data_csv, counts_at_kev=5750.0),  # above the 5.3 MeV alphas
            "m.yaml": MODEL_ONE,
        },
        "holds 1e+09 counts where every component's template is zero",
    ),
    # --- issue 26: silent accepts ----------------------------------------------------------------
    Case(
        "gdml-own-overlap-4mm",
        "silent",
        RUN,
        {"w.gdml": _writer(gdml_world, plate_z=-8.0), "c.yaml": gdml_config()},
        "volumes 'crystal_pv' and 'plate_pv' overlap by 4 mm",
        outputs=("r.h5",),
    ),
    Case(
        "gdml-own-overlap-allowed",
        "other",
        ["vertices", "c.yaml", "--out", "v.h5", "--allow-overlaps"],
        {"w.gdml": _writer(gdml_world, plate_z=-8.0), "c.yaml": gdml_config()},
    ),
    Case(
        "template-roi-outside-the-histogram",
        "silent",
        [*TEMPLATE, "--roi", "10 MeV", "11 MeV"],
        {"r.h5": real_run},
        "--roi: 10000 to 11000 keV is not inside the templates' energy range",
    ),
    Case(
        "model-roi-outside-the-templates",
        "traceback",
        ["model", "m.yaml"],
        {"t.h5": templates_file, "m.yaml": {**MODEL_ONE, "roi": ["10 MeV", "11 MeV"]}},
        "roi: 10000 to 11000 keV holds no bin centre of the templates",
    ),
    Case(
        "template-emax-1e30-mev",
        "silent",
        [*TEMPLATE, "--emax", "1e30 MeV"],
        {"r.h5": real_run},
        "is above 100 TeV",
    ),
    Case(
        "model-data-with-pseudo-data",
        "silent",
        ["model", "m.yaml", "--data", "d.csv", "--pseudo-data", "p.csv"],
        {"m.yaml": MODEL_TWO, "d.csv": data_csv},
        "--data: --pseudo-data draws a spectrum from the model and fits nothing",
    ),
    # --- issue 26: unclear -----------------------------------------------------------------------
    Case(
        "gdml-path-is-a-folder",
        "other",
        ["geometry", "list", "c.yaml"],
        {
            "g.gdml": lambda path: path.mkdir(),
            "c.yaml": {**gdml_config(), "world": {"gdml": "g.gdml"}},
        },
        "is a folder, not a GDML file",
    ),
    Case(
        "world-material-with-gdml",
        "other",
        RUN,
        {"w.gdml": gdml_world, "c.yaml": gdml_config(material="G4_AIR")},
        "(here gdml is w.gdml)",
    ),
    Case(
        "decay-nuclide-key",
        "other",
        RUN,
        {"c.yaml": config(source={"decay": {"nuclide": "Pb210"}})},
        "source.decay.nuclide: unknown key",
    ),
    Case(
        "material-neither-formula-nor-elements",
        "other",
        ["range", "alpha", "5 MeV", "m", "--config", "c.yaml"],
        {"c.yaml": {"materials": {"m": {"density": "2 g/cm3"}}}},
        "none is given",
    ),
    Case(
        "material-fraction-inf",
        "other",
        ["range", "alpha", "5 MeV", "m", "--config", "c.yaml"],
        {"c.yaml": "materials:\n  m: {elements: {Cu: .inf}, density: 8 g/cm3}\n"},
        "fractions must be finite numbers > 0",
    ),
    Case(
        "out-folder-is-a-file",
        "other",
        ["vertices", "c.yaml", "--out", "afile/v.h5"],
        {"c.yaml": config(), "afile": "not a folder\n"},
        "'afile' is a file, not a folder",
    ),
    Case(
        "crop-keeps-no-column",
        "other",
        GEN,
        {
            "g.txt": text_grid,
            "s.yaml": {"kind": "measured", "file": "g.txt", "crop_x": ["10 um", "20 um"]},
        },
        "x: 0.01 to 0.02 mm keeps 0 sample(s) of the map along x",
    ),
    Case(
        "decay-since-deposition-names-the-option",
        "other",
        ["decay", "Pb210", "--chain", "--since-deposition", "1e30 y"],
        {},
        "--since-deposition: the head has decayed away by then",
    ),
    # --- issue 26: the newcomer's first GDML (accepted) ------------------------------------------
    Case(
        "geometry-list-bare-gdml", "other", ["geometry", "list", "w.gdml"], {"w.gdml": gdml_world}
    ),
    Case(
        "geometry-list-world-only",
        "other",
        ["geometry", "list", "wo.yaml"],
        {"w.gdml": gdml_world, "wo.yaml": {"world": {"gdml": "w.gdml"}}},
    ),
    # --- issue 27: activeness, steps, allow_overlaps ------------------------------------------
    *[
        Case(
            f"activeness-{name}",
            "other",
            RUN,
            {"c.yaml": config(**{"targets.0.activeness": entries})},
            expect,
            outputs=("r.h5",),
        )
        for name, entries, expect in (
            (
                "fccd-negative",
                [{"fccd": "-1 mm", "dlf": 0.2}],
                "targets.0.activeness.0.fccd: must be greater than 0, got '-1 mm'",
            ),
            (
                "fccd-not-a-length",
                [{"fccd": "1 kg", "dlf": 0.2}],
                "targets.0.activeness.0.fccd: unknown length unit 'kg'",
            ),
            (
                "fccd-nan",
                [{"fccd": ".nan mm", "dlf": 0.2}],
                "targets.0.activeness.0.fccd: cannot read '.nan mm' as a length",
            ),
            (
                "dlf-negative",
                [{"fccd": "1 mm", "dlf": -0.1}],
                "targets.0.activeness.0.dlf: Input should be greater than or equal to 0",
            ),
            ("dlf-missing", [{"fccd": "1 mm"}], "targets.0.activeness.0.dlf: Field required"),
            (
                "faces-empty",
                [{"fccd": "1 mm", "dlf": 0.2, "faces": []}],
                "targets.0.activeness.0.faces: the selection names no face",
            ),
            (
                "faces-unknown",
                [{"fccd": "1 mm", "dlf": 0.2, "faces": ["+z", "nplus"]}],
                "targets.0.activeness.0.faces: ",
            ),
            (
                "not-a-list",
                {"fccd": "1 mm", "dlf": 0.2},
                "targets.0.activeness: Input should be a valid list",
            ),
            (
                "unknown-key",
                [{"fccd": "1 mm", "dlf": 0.2, "depth": "1 mm"}],
                "targets.0.activeness.0.depth: unknown key; valid keys here: fccd, dlf, faces",
            ),
        )
    ],
    Case(
        "steps-not-a-boolean",
        "other",
        RUN,
        {"c.yaml": config(output={"steps": "yes please"})},
        "output.steps: Input should be a valid boolean",
        outputs=("r.h5",),
    ),
    Case(
        "steps-with-a-portal-layer",
        "other",
        RUN,
        {"c.yaml": {**rough(PYRAMIDS, tiling="portal"), "output": {"steps": True}}},
        "output.steps: steps (and activeness) need native tiling; targets.0.rough.0 has tiling: "
        "portal",
        outputs=("r.h5",),
    ),
    Case(
        "allow-overlaps-not-a-boolean",
        "other",
        RUN,
        {"c.yaml": config(world={"allow_overlaps": "maybe"})},
        "world.allow_overlaps: Input should be a valid boolean",
        outputs=("r.h5",),
    ),
    Case(
        "allow-overlaps-without-gdml",
        "silent",
        RUN,
        {"c.yaml": config(world={"allow_overlaps": True})},
        "world: allow_overlaps: true is used only with gdml given",
        outputs=("r.h5",),
    ),
    # --- accepted now: a count written 1e6 in YAML (as --events 1e6 always was) -------------
    Case(
        "yaml-events-2e2",
        "other",
        ["vertices", "c.yaml", "--out", "v.h5"],
        {"c.yaml": config(run={"events": "2e2"})},
    ),
]


def digest(folder: Path) -> dict[str, str]:
    """sha256 of every file in ``folder``."""
    return {
        p.name: hashlib.sha256(p.read_bytes()).hexdigest() for p in folder.iterdir() if p.is_file()
    }


def classify(code: int | None, err: str, inputs_changed: bool) -> str:
    """What a user saw: refused (exit 2, one line), accepted, crash, traceback, hang, damaged."""
    lines = [line for line in err.splitlines() if not line.startswith("score4: warning:")]
    if code is None:
        return "hang"
    if inputs_changed:
        return "input damaged"
    if "Traceback" in err:
        return "traceback"
    if code < 0 or code >= 128 or "died" in err or "WorkerDied" in err:
        return "crash"
    if code == 0:
        return "accepted"
    if code == 2 and len(lines) == 1 and lines[0].startswith("score4: error:"):
        return "refused"
    return f"exit {code}"


def run_case(case: Case, timeout: float = 120.0) -> tuple[str, str]:
    """(classification, the last line of stderr) of ``case`` run as ``python -m score4``."""
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        case.write(folder)
        before = digest(folder)
        try:
            p = subprocess.run(
                [sys.executable, "-m", "score4", *case.argv],
                cwd=folder,
                capture_output=True,
                text=True,
                timeout=timeout,
                env={**os.environ, "PYTHONWARNINGS": "ignore"},
                check=False,
            )
            code, err = p.returncode, p.stderr
        except subprocess.TimeoutExpired:
            code, err = None, ""
        after = digest(folder)
        changed = any(after.get(name) != h for name, h in before.items())
        last = err.strip().splitlines()[-1] if err.strip() else ""
        return classify(code, err, changed), last


def main() -> None:
    """Classify every case and print the counts per class of the issue."""
    counts: Counter = Counter()
    rows = []
    for case in CASES:
        outcome, last = run_case(case)
        counts[(case.cls, outcome)] += 1
        rows.append({"case": case.id, "class": case.cls, "outcome": outcome, "said": last[:160]})
        print(f"{case.cls:9s} {case.id:34s} {outcome:12s} {last[:110]}", flush=True)
    print()
    for cls in ("crash", "traceback", "silent", "footgun", "other"):
        found = {o: n for (c, o), n in counts.items() if c == cls}
        print(f"{cls:9s} {sum(found.values()):3d} cases: {json.dumps(found)}")


if __name__ == "__main__":
    main()
