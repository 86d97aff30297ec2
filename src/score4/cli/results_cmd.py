"""``score4 plot`` and ``score4 export``: pictures and other file formats from results files.

Heavy modules (matplotlib, uproot) are imported inside the commands, so ``score4 --help``
stays fast.
"""

from __future__ import annotations

from pathlib import Path

import click

from ..errors import ConfigError, Score4Error

_FILE = click.Path(dir_okay=False, path_type=Path)
_SPECTRUM_ONLY = ("volume", "emin", "emax", "per_event", "errors")


def _energy(value: str | None, option: str) -> float | None:
    from score4.common.schema import quantity

    return None if value is None else quantity(value, "energy", option)


def _plot_surface(path: Path, out: Path) -> None:
    try:
        from ..surface.plot import plot_surface
    except ModuleNotFoundError as err:
        if err.name != "score4.surface.plot":
            raise
        raise Score4Error(
            f"{path}: plotting surface files needs score4.surface.plot, which this score4 does not "
            "have"
        ) from None
    from ..surface.store import load_surface

    plot_surface(load_surface(path), out)


@click.command()
@click.argument("files", metavar="FILE...", nargs=-1, required=True, type=_FILE)
@click.option("--out", "-o", required=True, type=_FILE, help="Image file (.png, .pdf, .svg, ...).")
@click.option("--volume", help="Volume to draw (default: all volumes).")
@click.option(
    "--bins", type=click.IntRange(min=1), help="Number of bins (default: the run's setting, 100)."
)
@click.option("--emin", help='Lower energy edge, e.g. "100 keV" (default 0).')
@click.option(
    "--emax",
    help='Upper energy edge, e.g. "6 MeV" (default: the run\'s setting or largest primary energy).',
)
@click.option(
    "--per-event",
    is_flag=True,
    help="Counts per keV per simulated event (compare runs of different sizes).",
)
@click.option("--linear", is_flag=True, help="Linear y axis (spectra are logarithmic by default).")
@click.option("--errors", is_flag=True, help="Poisson error bars (square root of the counts).")
@click.option("--label", "labels", multiple=True, help="Legend label, once per FILE in order.")
@click.option("--overwrite", is_flag=True, help="Replace an existing image file.")
def plot(
    files, out, volume, bins, emin, emax, per_event, linear, errors, labels, overwrite
) -> None:
    """Plot results files (energy-deposit spectra, overlaid), a vertex file (depth histogram)
    or a surface file (.s4s.h5, height map)."""
    from score4.analysis.plots import file_kind, plot_depths, plot_spectra

    from ..files import check_outputs

    check_outputs({"--out": out}, overwrite, {f"input {f}": f for f in files}, images=("--out",))
    kinds = [file_kind(f) for f in files]
    if len(set(kinds)) > 1:
        listing = ", ".join(f"{f.name} ({k})" for f, k in zip(files, kinds, strict=True))
        raise Score4Error(f"plot: cannot mix kinds of files in one plot: {listing}")
    kind = kinds[0]
    given = {
        "volume": volume,
        "emin": emin,
        "emax": emax,
        "per_event": per_event or None,
        "errors": errors or None,
    }
    if kind != "results":
        wrong = [f"--{k.replace('_', '-')}" for k in _SPECTRUM_ONLY if given[k] is not None]
        if wrong:
            raise ConfigError(
                f"plot: {', '.join(wrong)} apply to results files only, not to {kind} files"
            )
    if kind == "results":
        spectra = plot_spectra(
            list(files),
            out,
            volume=volume,
            bins=bins,
            emin=_energy(emin, "--emin"),
            emax=_energy(emax, "--emax"),
            labels=list(labels) or None,
            logy=not linear,
            per_event=per_event,
            errors=errors,
        )
        left = getattr(spectra, "left_out", [])
        click.echo(
            f"wrote {out}: {len(spectra)} spectra"
            + (
                f"; left out {len(left)} volume(s) without any deposit: "
                + ", ".join(s.volume for s in left)
                if left
                else ""
            )
        )
    elif kind == "vertices":
        hists = plot_depths(list(files), out, bins=bins, labels=list(labels) or None)
        click.echo(f"wrote {out}: {len(hists)} depth histogram(s)")
    else:
        if len(files) > 1:
            raise ConfigError(f"plot: one surface file at a time, got {len(files)}")
        if bins is not None or labels or linear:
            raise ConfigError("plot: --bins, --label and --linear do not apply to surface files")
        _plot_surface(files[0], out)
        click.echo(f"wrote {out}: height map of {files[0].name}")


@click.command()
@click.argument("results_file", metavar="FILE", type=_FILE)
@click.option("--csv", "csv_out", type=_FILE, help="Energy-deposit histogram(s) as CSV.")
@click.option(
    "--events-csv",
    "events_out",
    type=_FILE,
    help="One CSV row per event: primary energy and deposits.",
)
@click.option(
    "--root",
    "root_out",
    type=_FILE,
    help="ROOT file: TTree 'events', TH1D 'edep_<volume>', run record.",
)
@click.option("--volume", help="Volume for --csv (default: all volumes).")
@click.option(
    "--bins", type=click.IntRange(min=1), help="Histogram bins (default: the run's setting, 100)."
)
@click.option(
    "--emax",
    help='Histogram upper edge, e.g. "6 MeV" (default: the run\'s setting or largest primary '
    "energy).",
)
@click.option("--overwrite", is_flag=True, help="Replace existing output files.")
def export(results_file, csv_out, events_out, root_out, volume, bins, emax, overwrite) -> None:
    """Export a results FILE to CSV (histograms or events) and/or ROOT."""
    from score4.analysis.export import export_csv, export_events_csv, export_root, select_volumes
    from score4.runner.output import read_results

    from ..files import check_outputs

    if not (csv_out or events_out or root_out):
        raise ConfigError(
            "export: give at least one of --csv OUT.csv, --events-csv OUT.csv, --root OUT.root"
        )
    if volume is not None and not csv_out:
        raise ConfigError("export: --volume applies to --csv only")
    results = read_results(results_file)
    emax_mev = _energy(emax, "--emax")
    select_volumes(results, volume)  # every check before the first file is written
    check_outputs(
        {"--csv": csv_out, "--events-csv": events_out, "--root": root_out},
        overwrite,
        {"the results file": results_file},
    )
    if csv_out:
        export_csv(results, csv_out, volume=volume, bins=bins, emax=emax_mev)
        click.echo(f"wrote {csv_out}")
    if events_out:
        export_events_csv(results, events_out)
        click.echo(f"wrote {events_out}")
    if root_out:
        export_root(results, root_out, bins=bins, emax=emax_mev)
        click.echo(f"wrote {root_out}")
