"""``score4 template`` and ``score4 model``: from a run to templates, from templates to a model.

Heavy modules (uproot, matplotlib, iminuit) are imported inside the commands.
"""

from __future__ import annotations

import json
from pathlib import Path

import click

from ..errors import ConfigError

_FILE = click.Path(dir_okay=False, path_type=Path)


def _response(results, response_file: Path | None):
    """The response to apply: --response FILE, else the run configuration's ``response:``."""
    from ..response import ResponseConfig, load_response

    if response_file is not None:
        return load_response(response_file)
    stored = results.run.get("config", {}).get("response")
    return None if stored is None else ResponseConfig.model_validate(stored)


@click.command("template")
@click.argument("results_file", metavar="RUN.h5", type=_FILE)
@click.option("--activity", required=True,
              help="Activity of the source: per area for a surface source ('1 mBq/cm2'), per mass "
              "or volume for a bulk one ('5 mBq/kg'), total ('2 Bq') for a hand-made vertex file.")
@click.option("--livetime", help="Live time ('1 yr', '30 d'): adds expected counts per bin.")
@click.option("--bins", type=click.IntRange(min=1), help="Energy bins (default: the run's setting, 100).")
@click.option("--emin", help='Lower energy edge, e.g. "0 keV" (default 0).')
@click.option("--emax", help="Upper energy edge (default: the run's setting or largest primary energy).")
@click.option("--detector", "detectors", multiple=True,
              help="A scored volume to make templates for (repeat; default: all).")
@click.option("--response", "response_file", type=_FILE,
              help="Detector response YAML (quenching, resolution, threshold); default: the run "
              "configuration's response: section, if any.")
@click.option("--roi", nargs=2, metavar="LOW HIGH", help='Region of interest, e.g. --roi "5 MeV" "5.5 MeV".')
@click.option("--out", "-o", required=True, type=_FILE, help="Templates file (.h5, LH5 histograms).")
@click.option("--root", "root_out", type=_FILE, help="Also write the templates as ROOT TH1D/TH2D.")
@click.option("--plot", "plot_out", type=_FILE, help="Also draw the templates (one panel per detector).")
@click.option("--json", "as_json", is_flag=True, help="Print the rates as JSON.")
@click.option("--overwrite", is_flag=True, help="Replace existing output files.")
def template(results_file, activity, livetime, bins, emin, emax, detectors, response_file, roi,
             out, root_out, plot_out, as_json, overwrite) -> None:  # fmt: skip
    """Templates of RUN.h5 in counts/(keV kg day) per detector for the given activity."""
    from ..files import check_output_file
    from ..output import read_results
    from ..templates import build_templates, write_templates_h5, write_templates_root

    for option, path in (("--out", out), ("--root", root_out), ("--plot", plot_out)):
        if path is not None:
            check_output_file(path, overwrite, option)
    results = read_results(results_file)
    response = _response(results, response_file)
    ts = build_templates(
        results, activity, detectors=list(detectors) or None, bins=bins, emin=emin, emax=emax,
        response=response, livetime=livetime, roi=tuple(roi) if roi else None,
    )  # fmt: skip
    write_templates_h5(ts, out)
    written = [str(out)]
    if root_out:
        write_templates_root(ts, root_out)
        written.append(str(root_out))
    if plot_out:
        from ..plots import plot_templates

        plot_templates(ts, plot_out)
        written.append(str(plot_out))
    if as_json:
        click.echo(json.dumps(ts.to_json(), indent=2))
        return
    _print_template_summary(ts, written)


def _print_template_summary(ts, written: list[str]) -> None:
    act = ts.activity
    click.echo(f"wrote {', '.join(written)}")
    click.echo(f"  activity      {act.text} x {act.size_text} = {act.total_bq:.6g} Bq")
    click.echo(f"  decays        {ts.simulated_decays} simulated")
    click.echo(f"  stage         {ts.final.name}" + (" (after the response)" if ts.response else ""))
    for d in ts.detectors:
        t = ts.final.totals[d]
        line = (f"  {d}: {ts.masses[d]:.6g} kg, {t['counts_per_kg_day']:.4g} +- "
                f"{t['counts_per_kg_day_error']:.2g} counts/(kg day) ({t['simulated_counts']} events)")  # fmt: skip
        if ts.roi_kev:
            line += (f"; ROI {ts.roi_kev[0]:g}-{ts.roi_kev[1]:g} keV: {t['roi_counts_per_keV_kg_day']:.4g} +- "
                     f"{t['roi_counts_per_keV_kg_day_error']:.2g} counts/(keV kg day)")  # fmt: skip
        click.echo(line)


__all__ = ["ConfigError", "template"]
