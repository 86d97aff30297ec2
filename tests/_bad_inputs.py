"""The bad inputs of issue 20's "Why" list, one case each, for tests/test_bad_inputs.py.

Each case writes its files into an empty folder and gives the command line; it says which
class of fault the input caused when the issue was filed (crash, traceback, silent accept,
footgun, refused) and the words the one-line error must hold now.

Run as a script it classifies every case as a user meets it, each command in its own process
(with a timeout), and prints the counts per class; run it against any checkout with
``PYTHONPATH=<checkout>/src``:

    .venv/bin/python tests/_bad_inputs.py            # this checkout
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

BASE = {
    "physics": "lite",
    "targets": [
        {
            "name": "crystal",
            "material": "G4_Si",
            "size": ["1 cm", "1 cm", "1 cm"],
            "position": ["0 cm", "0 cm", "-0.5 cm"],
        }
    ],
    "source": {
        "particle": "alpha",
        "energy": "5.3 MeV",
        "surface": {"volume": "crystal", "face": "+z"},
    },
    "run": {"events": 20, "seed": 7},
}
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
