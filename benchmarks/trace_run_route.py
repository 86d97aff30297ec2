"""The route of a configuration from ``score4 run`` to the workers: which step runs how often.

    .venv/bin/python benchmarks/trace_run_route.py CONFIG.yaml [--events 50] [--jobs 1]

Runs ``score4 run CONFIG --events N`` with a profile hook (``sys.setprofile``, installed by a
``sitecustomize`` module on ``PYTHONPATH``, so spawned workers carry it too) that logs every call
of the steps a configuration goes through: reading and validating it, planning (scene, source,
physics, the GDML model and fingerprint), the parent's checks, the worker's rebuild of the plan
and its Geant4 world. Prints, per process (the parent, each worker, a GDML reader
subprocess), how many times each step ran. The GDML file is read by Geant4 in
``geometry/gdml.py:read_gdml`` and checked as XML in ``world/gdml_files.py:gdml_files``.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
from collections import Counter
from pathlib import Path

STEPS = [
    "load_config",
    "parse_config",
    "plan_run",
    "_rebuild",
    "build_scene",
    "make_source",
    "resolve_physics",
    "gdml_files",
    "model_key",
    "load_geometry_model",
    "keyed_geometry_model",
    "read_gdml",
    "_read_in_subprocess",
    "config_fingerprint",
    "preflight",
    "build_world",
    "build_gdml_world",
    "check_materials",
    "run_normalisation",
    "check_clearance",
    "resolve_targets",
]

HOOK = """
import os, sys
STEPS = set({steps!r})
def _trace(frame, event, arg):
    if event == "call":
        code = frame.f_code
        if "score4" in code.co_filename and (
            code.co_name in STEPS
            or (code.co_name == "__init__" and code.co_filename.endswith("sim/simulation.py")
                and frame.f_locals.get("self").__class__.__name__ == "Simulation")
        ):
            name = "Simulation" if code.co_name == "__init__" else code.co_name
            where = code.co_filename.split("score4/")[-1]
            with open({log!r}, "a") as f:
                f.write(f"{{os.getpid()}} {{where}}:{{name}}\\n")
sys.setprofile(_trace)
"""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("config", type=Path)
    parser.add_argument("--events", type=int, default=50)
    parser.add_argument("--jobs", type=int, default=1)
    args = parser.parse_args()
    score4 = Path(sys.executable).with_name("score4")
    with tempfile.TemporaryDirectory(prefix="score4-route-") as tmp:
        log = Path(tmp) / "calls.txt"
        (Path(tmp) / "sitecustomize.py").write_text(HOOK.format(steps=STEPS, log=str(log)))
        subprocess.run(
            [
                str(score4),
                "-q",
                "run",
                str(args.config),
                "--events",
                str(args.events),
                "--jobs",
                str(args.jobs),
                "--out",
                str(Path(tmp) / "out.h5"),
            ],
            env={**__import__("os").environ, "PYTHONPATH": tmp},
            check=True,
        )
        lines = [line.split() for line in log.read_text().splitlines()]
    order = list(dict.fromkeys(pid for pid, _ in lines))
    for k, pid in enumerate(order):
        calls = Counter(step for p, step in lines if p == pid)
        role = "parent" if k == 0 else f"process {k}"
        if "sim/simulation.py:Simulation" in calls:
            role = f"worker {k}"
        elif "geometry/gdml.py:read_gdml" in calls:
            role = f"GDML reader {k}"
        print(f"{role} (pid {pid}):")
        for step, n in sorted(calls.items()):
            print(f"  {n:3d}  {step}")


if __name__ == "__main__":
    main()
