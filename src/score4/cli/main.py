"""``score4``: the command-line entry point.

Input errors (:class:`~score4.errors.Score4Error`) and click's usage errors (unknown option,
missing argument, bad value) are printed as one line ``score4: error: <message>`` and end the
command with exit status 2. ``score4 -q COMMAND`` keeps stderr to errors only.
"""

from __future__ import annotations

import json
import os
import sys
import warnings
from importlib.metadata import version
from pathlib import Path

import click

from score4.common.units import count_text

from .. import __version__
from ..errors import ConfigError, RunInterrupted, Score4Error, Score4Warning, brief, naming_file
from .data_cmd import data
from .decay_cmd import decay_command
from .geometry_cmd import geometry
from .macro_cmd import import_macro
from .quiet import is_quiet, notice, set_quiet
from .range_cmd import range_command
from .results_cmd import export, plot
from .surface_cmd import surface
from .templates_cmd import model, template
from .usage import command_path, usage_error_line


class EventCount(click.ParamType):
    """A positive whole number of events, also written like 1e6 or 2.5e5."""

    name = "integer"

    def convert(self, value, param, ctx):
        from score4.common.limits import too_many_events
        from score4.common.units import parse_count

        try:
            number = parse_count(value)
        except ConfigError:
            self.fail(f"{brief(value)} is not a whole number of events", param, ctx)
        if number < 1:
            self.fail(f"{brief(value)}: need at least 1 event", param, ctx)
        problem = too_many_events(number)
        if problem:
            self.fail(problem, param, ctx)
        return number


EVENTS = EventCount()


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(
    __version__,
    prog_name="score4",
    message=f"%(prog)s %(version)s (geant4_pybind {version('geant4_pybind')})",
)
@click.option(
    "--quiet",
    "-q",
    is_flag=True,
    help="Any command: no progress, notices or warnings on stderr (errors still print).",
)
@click.pass_context
def cli(ctx: click.Context, quiet: bool) -> None:
    """Radioactive contamination on and below rough surfaces, simulated with Geant4."""
    if quiet:
        set_quiet(ctx)


_ALLOW_OVERLAPS = click.option(
    "--allow-overlaps",
    is_flag=True,
    help="Run although the GDML world's own volumes overlap (world: {allow_overlaps: true}).",
)


def _load_with_overrides(
    config_file: Path, events: int | None, seed: int | None, allow_overlaps: bool = False
):
    """The configuration with ``--events``/``--seed`` written into its run section."""
    from score4.inputs.config import allowing_overlaps, load_config

    config = load_config(config_file)
    if allow_overlaps:
        config = allowing_overlaps(config)
    overrides = {k: v for k, v in {"events": events, "seed": seed}.items() if v is not None}
    if overrides:
        config = config.model_copy(update={"run": config.run.model_copy(update=overrides)})
    return config


@cli.command()
@click.argument(
    "config_file", metavar="CONFIG.yaml", type=click.Path(dir_okay=False, path_type=Path)
)
@click.option(
    "--events", type=EVENTS, help="Number of events, e.g. 5000 or 1e6 (overrides run.events)."
)
@click.option(
    "--seed", type=click.IntRange(min=0, max=2**63 - 1), help="Random seed (overrides run.seed)."
)
@click.option(
    "--out",
    type=click.Path(path_type=Path),
    help="Results file (.h5); default: <config name>.h5 here.",
)
@click.option("--overwrite", is_flag=True, help="Replace an existing results file.")
@click.option(
    "--jobs",
    "-j",
    type=click.IntRange(min=1),
    default=1,
    show_default=True,
    help="Worker processes.",
)
@click.option(
    "--resume", is_flag=True, help="Continue an interrupted run, keeping its finished chunks."
)
@click.option(
    "--cluster",
    metavar="dask|ADDRESS",
    help="Run the chunks with Dask: 'dask' for a local Dask cluster of --jobs worker processes, or "
    "the address of a running scheduler (tcp://host:8786). Needs: pip install 'score4[cluster]'.",
)
@click.option(
    "--quiet",
    "-q",
    is_flag=True,
    help="No progress bar, notices or warnings on stderr: errors only (as score4 -q run); at a "
    "terminal it still says once that it builds a TRIM library (a wait of up to minutes).",
)
@_ALLOW_OVERLAPS
@click.pass_context
def run(
    ctx: click.Context,
    config_file: Path,
    events,
    seed,
    out,
    overwrite,
    jobs,
    resume,
    cluster,
    quiet,
    allow_overlaps,
) -> None:
    """Simulate the run described in CONFIG.yaml and write an HDF5 results file."""
    from score4.common.schema import input_paths
    from score4.runner.engine import run as run_engine
    from score4.runner.output import read_results, summarize

    from ..files import check_outputs

    if quiet:
        set_quiet(ctx)
    quiet = is_quiet()

    config = _load_with_overrides(config_file, events, seed, allow_overlaps)
    out = out or Path(config_file.stem + ".h5")
    if cluster is None:  # local workers: each a Geant4 process of its own
        from score4.common import limits

        limits.check_memory(
            jobs * limits.WORKER_BYTES,
            f"running {count_text(jobs, 'Geant4 process', 'Geant4 processes')} (at least 150 MB "
            "each)",
            "--jobs",
            "use fewer --jobs",
        )
    check_outputs(  # the results and, beside them, Geant4's log
        {"--out": out, "its Geant4 log": out.with_name(out.stem + ".geant4.log")},
        True,
        {"the configuration": config_file, **input_paths(config)},
    )
    with naming_file(config_file):
        run_engine(
            config,
            out,
            overwrite=overwrite,
            jobs=jobs,
            resume=resume,
            progress=not quiet,
            echo=notice,
            cluster=cluster,
        )
    summary = summarize(read_results(out))
    click.echo(
        f"wrote {out}: {count_text(summary['n_events'], 'event')}, physics "
        f"{summary['physics_mode']}, seed {summary['seed']}"
    )


@cli.command()
@click.argument(
    "config_file", metavar="CONFIG.yaml", type=click.Path(dir_okay=False, path_type=Path)
)
@click.option("--n", "n_events", type=EVENTS, help="Number of events (default: run.events).")
@click.option(
    "--seed", type=click.IntRange(min=0, max=2**63 - 1), help="Random seed (default: run.seed)."
)
@click.option(
    "--out", type=click.Path(path_type=Path), required=True, help="Vertex file to write (.h5)."
)
@click.option("--overwrite", is_flag=True, help="Replace an existing file.")
@_ALLOW_OVERLAPS
def vertices(
    config_file: Path, n_events, seed, out: Path, overwrite: bool, allow_overlaps: bool
) -> None:
    """Draw the source vertices of CONFIG.yaml into an HDF5 vertex file (no Geant4 run).

    Columns: event, particle, energy (MeV), xloc/yloc/zloc (mm), dirx/diry/dirz, depth (mm),
    facet, patch, with units attributes (LEGEND/remage style). The events are drawn exactly as
    'score4 run' draws them (in blocks of 1000 with their own random streams), so running the
    file (source: {vertices: FILE}) with the same seed reproduces the direct run event by event,
    and the first N rows are the vertices of a run of N events.
    """
    from score4.common import limits
    from score4.common.schema import input_paths
    from score4.inputs.config import config_to_dict
    from score4.runner.physics_choice import resolve_physics
    from score4.runner.run_plan import plan_run
    from score4.source.event_blocks import BLOCK_EVENTS

    from ..files import check_output_file
    from ..source.build import source_geometry
    from ..source.vertex_file import write_vertex_file

    config = _load_with_overrides(config_file, n_events, seed, allow_overlaps)
    if config.source.vertices is not None:
        raise ConfigError(
            f"{config_file}: source.vertices: the source already reads a vertex file; nothing to "
            "draw"
        )
    if config.source.run_unit == "atom":
        raise ConfigError(
            f"{config_file}: source.decay.implantation: the daughters' vertices are where the "
            "run's TRIM replay stops the alpha recoils, so they cannot be drawn beforehand; "
            "run the configuration with 'score4 run'"
        )
    check_output_file(
        out, overwrite, "--out", {"the configuration": config_file, **input_paths(config)}
    )
    n, seed = config.run.events, config.run.seed
    with naming_file(config_file):
        # the plan of a run (world, source); drawing vertices tracks nothing, so the physics is
        # not asked of the installed data (lite needs none)
        plan = plan_run(config, physics=resolve_physics("lite"))
        scene, source = plan.scene, plan.source
        assert source is not None  # a plan with its source
        sample = source.events(seed, 0, min(n, BLOCK_EVENTS))
        limits.check_memory(
            2 * n * limits.PRIMARY_BYTES * len(sample) / sample.n_events,
            f"writing the vertices of {n} events",
            "--n",
            "write several files with different --seed values",
        )
        primaries = source.events(seed, 0, n)
        where = source_geometry(config, scene)
    write_vertex_file(out, primaries, config_to_dict(config), seed, where)
    text = (
        f"wrote {out}: {count_text(n, 'event')}, "
        f"{count_text(len(primaries.event), 'primary', 'primaries')}"
    )
    if "depth" in primaries.extra:
        depth = primaries.extra["depth"]
        text += (
            f", depth mean {depth.mean() * 1e6:.3g} nm (min {depth.min() * 1e6:.3g}, max "
            f"{depth.max() * 1e6:.3g} nm)"
        )
    else:
        text += f", uniform in {where['volume']} ({where['volume_mm3']:.6g} mm3)"
    click.echo(text)


@cli.command()
@click.argument("results_file", metavar="FILE.h5", type=click.Path(dir_okay=False, path_type=Path))
@click.option("--json", "as_json", is_flag=True, help="Machine-readable JSON.")
@click.option(
    "--bins", type=click.IntRange(min=1), help="Histogram bins (default: the run's setting, 100)."
)
@click.option(
    "--threshold",
    default="10 keV",
    show_default=True,
    help="Energy a volume must exceed to count as hit (rates and multiplicity).",
)
def summary(results_file: Path, as_json: bool, bins, threshold: str) -> None:
    """Summarise a results file: events, physics, energy deposit per volume, per-volume rates
    above --threshold and the multiplicity (events with 1, 2, ... volumes above it)."""
    from score4.common.units import parse_quantity
    from score4.runner.output import read_results, summarize

    limit = parse_quantity(threshold, "energy", "--threshold")
    if limit < 0:
        raise ConfigError(f"--threshold: must be >= 0, got {threshold!r}")
    results = read_results(results_file)
    s = summarize(results, bins=bins, threshold=limit)
    run = results.run
    if "n_atoms" in run:  # per-atom histories: a chain with recoil implantation
        moved = run.get("implantation", {})
        s["atoms"] = {
            "n_atoms": int(run["n_atoms"]),
            "nuclide": run.get("activity_nuclide"),
            "recoils": int(moved.get("recoils", 0)),
            "left_world": int(moved.get("left_world", 0)),
            "lost_decays": int(moved.get("lost_decays", 0)),
            "simulated_decays": float(run.get("simulated_decays", 0)),
        }
    if as_json:
        click.echo(json.dumps(s, indent=2))
        return
    click.echo(f"{s['file']}")
    click.echo(f"  events        {s['n_events']}")
    if "atoms" in s:
        a = s["atoms"]
        click.echo(
            f"  atoms         {a['n_atoms']} deposited {a['nuclide']} atoms "
            f"followed down the chain; {a['recoils']} recoils moved an atom, "
            f"{a['left_world']} left the world with it "
            f"({a['lost_decays']} decays lost); simulated_decays "
            f"{a['simulated_decays']:g} (one per atom)"
        )
    click.echo(
        f"  physics       {s['physics_mode']}"
        + (f" ({run.get('physics_lacks')})" if run.get("physics_lacks") else "")
    )
    click.echo(f"  seed          {s['seed']}")
    if results.active:
        click.echo(
            "  energy        active energy (targets[].activeness: deposits weighted by the "
            "charge collection at their distance to the faces; /events/active_edep)"
        )
    click.echo(
        f"  versions      score4 {run.get('score4_version')}, Geant4 {run.get('geant4_version')}, "
        f"geant4_pybind {run.get('geant4_pybind_version')}"
    )
    click.echo(f"  wall time     {run.get('wall_time_s')} s")
    if "energy_violations" in run:
        excess = float(run.get("energy_max_excess_MeV", 0.0)) * 1e3
        click.echo(
            f"  energy check  {run['energy_violations']} events deposit more than their primaries' "
            f"energy + 1 eV" + (f" (largest excess {excess:.4g} keV)" if excess > 0 else "")
        )
    if float(run.get("untracked_gamma_energy_MeV", 0.0)) > 0:
        click.echo(
            f"  photons       {float(run['untracked_gamma_energy_MeV']):.6g} MeV in "
            f"{run.get('untracked_gamma_events', 0)} events not tracked (lite physics: gamma and "
            f"X-ray primaries, annihilation photons; per event: events/untracked_gamma_energy)"
        )
    if int(run.get("stuck_events_aborted", 0)):
        click.echo(
            f"  stuck tracks  {run['stuck_events_aborted']} events aborted by Geant4 (a track "
            "stuck on a volume boundary was killed: their deposits are incomplete)"
        )
    emax = max(float(results.primary_energy.max(initial=0.0)), 1e-12)
    for v in s["volumes"]:
        e = results.edep[v["name"]]
        full = int((e > 0.999 * results.primary_energy).sum())
        click.echo(
            f"  volume {v['name']}: mean deposit {v['mean_edep_MeV']:.4f} MeV, "
            f"{v['n_nonzero']} events with deposit, {full} with (nearly) the full energy "
            f"(max primary energy {emax:.4g} MeV)"
        )
    _echo_rates(s, limit)


def _echo_rates(s: dict, limit: float) -> None:
    """Per-volume rates above the threshold; the multiplicity only when there is more than one
    volume (with one it says nothing the rate does not)."""
    volumes = s["volumes"]
    keV = f"{limit * 1e3:g} keV"
    for v in volumes:
        mass = v.get("mass_kg")
        per_kg = (
            f", {v['rate_per_event_per_kg']:.4g} /(kg event) ({mass * 1e3:.4g} g "
            f"{v.get('material')})"
            if mass
            else ""
        )
        alone = f"; alone (multiplicity 1) {v['alone_above_threshold']}" if len(volumes) > 1 else ""
        head = f"    {v['name']}:" if len(volumes) > 1 else f"  above {keV}:"
        if len(volumes) > 1 and v is volumes[0]:
            click.echo(f"  above {keV} (rate = events above / simulated events):")
        click.echo(
            f"{head} {count_text(v['above_threshold'], 'event')}, rate "
            f"{v['rate_per_event']:.4g} /event"
            f"{per_kg}{alone}"
        )
    if len(volumes) > 1:
        counts = s["multiplicity"]["events"]
        shown = ", ".join(f"{m}: {c}" for m, c in counts.items() if c or m <= 2)
        click.echo(f"  multiplicity (volumes above {keV}: events) {shown}")


cli.add_command(data)
cli.add_command(plot)
cli.add_command(export)
cli.add_command(surface)
cli.add_command(import_macro)
cli.add_command(geometry)
cli.add_command(range_command)
cli.add_command(template)
cli.add_command(model)
cli.add_command(decay_command)


_SHOWN: set[str] = set()  # score4 warnings said in this command


def _show_warning(message, category, filename, lineno, file=None, line=None) -> None:
    """score4 warnings as one line, once, without the source location Python adds."""
    if not issubclass(category, Score4Warning):
        _PYTHON_SHOWWARNING(message, category, filename, lineno, file, line)
    elif str(message) not in _SHOWN:
        _SHOWN.add(str(message))
        click.echo(f"score4: warning: {message}", err=True)


_PYTHON_SHOWWARNING = warnings.showwarning
# click >= 8.2 raises this (a UsageError) for a group called without a command
_NO_ARGS_IS_HELP = getattr(click.exceptions, "NoArgsIsHelpError", ())


#: Longest error line the CLI prints; longer messages (which quote other programs' output) are cut.
MAX_ERROR_CHARS = 2000


def one_line(text: str) -> str:
    """An error message as one line of at most MAX_ERROR_CHARS characters."""
    text = " ".join(part.strip() for part in text.splitlines() if part.strip())
    return text if len(text) <= MAX_ERROR_CHARS else text[: MAX_ERROR_CHARS - 5] + " [...]"


def main(argv: list[str] | None = None) -> int:
    """Run the CLI; return the exit status (2 for input errors)."""
    _SHOWN.clear()
    with warnings.catch_warnings():
        warnings.simplefilter("always", Score4Warning)  # _show_warning says each text once
        warnings.showwarning = _show_warning
        return _main(argv)


def _main(argv: list[str] | None) -> int:
    try:
        status = cli.main(args=argv, prog_name="score4", standalone_mode=False)
    except Score4Error as err:
        click.echo(f"score4: error: {one_line(str(err))}", err=True)
        return 2
    except click.exceptions.Exit as err:
        return err.exit_code
    except _NO_ARGS_IS_HELP as err:  # a command group alone: its help, as click shows it
        err.show()
        return 2
    except click.UsageError as err:
        path = command_path(cli, sys.argv[1:] if argv is None else list(argv))
        click.echo(f"score4: error: {one_line(usage_error_line(err, path))}", err=True)
        return 2
    except click.ClickException as err:
        click.echo(f"score4: error: {one_line(err.format_message())}", err=True)
        return 2
    except click.exceptions.Abort as err:
        cause = err.__cause__ or err.__context__
        said = str(cause) if isinstance(cause, RunInterrupted) and str(cause) else "aborted"
        click.echo(f"score4: {said}", err=True)
        return 130
    except RunInterrupted as err:  # not turned into Abort (raised outside click's own call)
        click.echo(f"score4: {str(err) or 'aborted'}", err=True)
        return 130
    # with standalone_mode=False click returns (not raises) the code of a ctx.exit / Exit(n)
    return status if isinstance(status, int) else 0


def entry_point() -> None:
    """Console-script entry point."""
    _spawn_without_main()
    status = main()
    if status == 130:
        # Interrupted: everything is closed and cleaned up already. Skip the interpreter's
        # teardown of numpy/scipy/h5py/pydantic, which takes ~0.5-1.5 s on a loaded machine,
        # so that Ctrl-C ends the command at once.
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(status)
    sys.exit(status)


def _spawn_without_main() -> None:
    """Let spawned worker processes skip the console script, as under ``python -m score4``.

    A spawned process runs the parent's main script again (as ``__mp_main__``) unless the main
    module has a spec naming a package's ``__main__``. The ``score4`` script only imports this
    module, which a worker does not need: importing it (click, pydantic, every command) was
    0.3 s of each worker's start-up.
    """
    main_module = sys.modules.get("__main__")
    if main_module is not None and getattr(main_module, "__spec__", None) is None:
        import importlib.machinery

        main_module.__spec__ = importlib.machinery.ModuleSpec("score4.__main__", None)


if __name__ == "__main__":
    entry_point()
