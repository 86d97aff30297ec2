"""How a run plan should reach a worker: the resolved plan pickled, or its recipe re-planned.

    .venv/bin/python benchmarks/bench_run_plan.py [--rounds 5] [--face-cm 10]

A :class:`score4.runner.run_plan.RunPlan` holds the resolved scene (targets, rough layers with their
surfaces and patch maps) and the source. A worker (a spawned process, or a Dask task: Dask
pickles a task's arguments with every task) can receive either

  resolved   the scene and the source pickled as they are, or
  recipe     the configuration, seed, physics choice, fingerprint and GDML volume model
             (what ``pickle.dumps(plan)`` writes), the scene and source rebuilt on unpickling.

For one rough face of ``--face-cm`` x ``--face-cm`` (the target of examples/paper_a_rough.yaml
made that large), with two surfaces: the paper's pyramids (0.5 mm patches) and the 128 um
self-affine random surface of examples/surfaces/self_affine.yaml. Printed per case (CPU seconds
of this process, medians of ``--rounds`` interleaved rounds): the first planning (surfaces built
from their descriptions), the pickle size and dumps + loads time of each form, the rebuild
(loads of the recipe, which re-plans; the in-process cache of rebuilt plans is emptied first).
"""

from __future__ import annotations

import argparse
import pickle
import statistics
import time
from pathlib import Path

import yaml

from score4.inputs.config import parse_config
from score4.runner import run_plan
from score4.runner.run_plan import plan_run

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"


def config(face_cm: float, surface: str):
    data = yaml.safe_load((EXAMPLES / "paper_a_rough.yaml").read_text())
    side = f"{face_cm} cm"
    if surface == "self_affine":  # whole 0.128 mm patches: 781 across 10 cm
        data["surfaces"] = {
            "pyramids": yaml.safe_load((EXAMPLES / "surfaces/self_affine.yaml").read_text())
        }
        side = f"{round(face_cm * 10 / 0.128) * 0.128:.3f} mm"
    data["targets"][0]["size"] = [side, side, "1 mm"]
    return parse_config(data, base_dir=EXAMPLES)


def cpu(fn):
    t0 = time.process_time()
    out = fn()
    return time.process_time() - t0, out


def measure(cfg) -> dict:
    plan_s, plan = cpu(lambda: plan_run(cfg))
    resolved_dump_s, resolved = cpu(lambda: pickle.dumps((plan.scene, plan.source), protocol=5))
    resolved_load_s, _ = cpu(lambda: pickle.loads(resolved))
    recipe_dump_s, recipe = cpu(lambda: pickle.dumps(plan, protocol=5))
    run_plan._REBUILT.clear()
    rebuild_s, rebuilt = cpu(lambda: pickle.loads(recipe))
    assert rebuilt == plan
    assert (
        rebuilt.scene.layers[0].patch_map.variants == plan.scene.layers[0].patch_map.variants
    ).all()
    return {
        "plan_s": plan_s,
        "resolved_MB": len(resolved) / 1e6,
        "resolved_s": resolved_dump_s + resolved_load_s,
        "recipe_kB": len(recipe) / 1e3,
        "recipe_dump_s": recipe_dump_s,
        "rebuild_s": rebuild_s,
        "patches": plan.scene.layers[0].patch_map.variants.size,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--face-cm", type=float, default=10.0)
    args = parser.parse_args()
    cases = {name: config(args.face_cm, name) for name in ("pyramids", "self_affine")}
    rows: dict[str, list[dict]] = {name: [] for name in cases}
    for _ in range(args.rounds):
        for name, cfg in cases.items():
            rows[name].append(measure(cfg))
    load = " ".join(Path("/proc/loadavg").read_text().split()[:3])
    print(f"{args.face_cm:g} cm rough face; medians of {args.rounds} rounds (CPU s); load {load}")
    columns = [  # (heading, key, format)
        ("patches", "patches", "d"),
        ("plan s", "plan_s", ".3f"),
        ("resolved MB", "resolved_MB", ".2f"),
        ("dumps+loads s", "resolved_s", ".4f"),
        ("recipe kB", "recipe_kB", ".1f"),
        ("recipe dumps s", "recipe_dump_s", ".5f"),
        ("rebuild s", "rebuild_s", ".3f"),
    ]
    print(f"{'surface':12}" + "".join(f" {h:>{len(h) + 2}}" for h, _, _ in columns))
    for name, found in rows.items():
        med = {k: statistics.median(r[k] for r in found) for _, k, _ in columns}
        med["patches"] = int(med["patches"])
        print(f"{name:12}" + "".join(f" {med[k]:>{len(h) + 2}{f}}" for h, k, f in columns))


if __name__ == "__main__":
    main()
