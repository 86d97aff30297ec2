"""``score4 template`` and ``score4 model``: from a run to templates, from templates to a model.

Heavy modules (uproot, matplotlib, iminuit) are imported inside the commands.
"""

from __future__ import annotations

import json
from pathlib import Path

import click

from ..errors import ConfigError, naming_file

_FILE = click.Path(dir_okay=False, path_type=Path)


def _response(results, response_file: Path | None):
    """The response to apply: --response FILE, else the run configuration's ``response:``."""
    from score4.inputs.response_spec import ResponseConfig, load_response

    if response_file is not None:
        return load_response(response_file)
    stored = results.run.get("config", {}).get("response")
    if stored is None:
        return None
    return ResponseConfig.model_validate(stored, context={"base_dir": None, "stored": True})


@click.command("template")
@click.argument("results_file", metavar="RUN.h5", type=_FILE)
@click.option(
    "--activity",
    required=True,
    help="Activity of the source: per area for a surface source ('1 mBq/cm2'), per mass "
    "or volume for a bulk one ('5 mBq/kg'), total ('2 Bq') for a hand-made vertex file.",
)
@click.option("--livetime", help="Live time ('1 yr', '30 d'): adds expected counts per bin.")
@click.option(
    "--bins", type=click.IntRange(min=1), help="Energy bins (default: the run's setting, 100)."
)
@click.option("--emin", help='Lower energy edge, e.g. "0 keV" (default 0).')
@click.option(
    "--emax", help="Upper energy edge (default: the run's setting or largest primary energy)."
)
@click.option(
    "--detector",
    "detectors",
    multiple=True,
    help="A scored volume to make templates for (repeat; default: all).",
)
@click.option(
    "--response",
    "response_file",
    type=_FILE,
    help="Detector response YAML (quenching, resolution, threshold); default: the run "
    "configuration's response: section, if any.",
)
@click.option(
    "--roi", nargs=2, metavar="LOW HIGH", help='Region of interest, e.g. --roi "5 MeV" "5.5 MeV".'
)
@click.option(
    "--out", "-o", required=True, type=_FILE, help="Templates file (.h5, LH5 histograms)."
)
@click.option("--root", "root_out", type=_FILE, help="Also write the templates as ROOT TH1D/TH2D.")
@click.option(
    "--plot", "plot_out", type=_FILE, help="Also draw the templates (one panel per detector)."
)
@click.option("--json", "as_json", is_flag=True, help="Print the rates as JSON.")
@click.option("--overwrite", is_flag=True, help="Replace existing output files.")
def template(
    results_file,
    activity,
    livetime,
    bins,
    emin,
    emax,
    detectors,
    response_file,
    roi,
    out,
    root_out,
    plot_out,
    as_json,
    overwrite,
) -> None:
    """Templates of RUN.h5 in counts/(keV kg day) per detector for the given activity."""
    from score4.analysis.templates import build_templates, write_templates_h5, write_templates_root
    from score4.runner.output import read_results

    from ..files import check_outputs

    check_outputs(
        {"--out": out, "--root": root_out, "--plot": plot_out},
        overwrite,
        {"the run results": results_file, "the --response file": response_file},
        images=("--plot",),
    )
    results = read_results(results_file)
    response = _response(results, response_file)
    ts = build_templates(
        results,
        activity,
        detectors=list(detectors) or None,
        bins=bins,
        emin=emin,
        emax=emax,
        response=response,
        livetime=livetime,
        roi=tuple(roi) if roi else None,
    )
    write_templates_h5(ts, out)
    written = [str(out)]
    if root_out:
        write_templates_root(ts, root_out)
        written.append(str(root_out))
    if plot_out:
        from score4.analysis.plots import plot_templates

        plot_templates(ts, plot_out)
        written.append(str(plot_out))
    if as_json:
        click.echo(json.dumps(ts.to_json(), indent=2))
        return
    _print_template_summary(ts, written)
    if results.active:
        click.echo(
            "  energy        active energy of the run (targets[].activeness, /events/active_edep)"
        )


def _print_template_summary(ts, written: list[str]) -> None:
    from score4.common.units import count_text

    act = ts.activity
    click.echo(f"wrote {', '.join(written)}")
    click.echo(f"  activity      {act.text} x {act.size_text} = {act.total_bq:.6g} Bq")
    click.echo(f"  decays        {ts.simulated_decays:.10g} simulated")
    click.echo(
        f"  stage         {ts.final.name}" + (" (after the response)" if ts.response else "")
    )
    for d in ts.detectors:
        t = ts.final.totals[d]
        line = (
            f"  {d}: {ts.masses[d]:.6g} kg, {t['counts_per_kg_day']:.4g} +- "
            f"{t['counts_per_kg_day_error']:.2g} counts/(kg day) "
            f"({count_text(t['simulated_counts'], 'event')})"
        )
        if ts.roi_kev:
            line += (
                f"; ROI {ts.roi_kev[0]:g}-{ts.roi_kev[1]:g} keV: "
                f"{t['roi_counts_per_keV_kg_day']:.4g} +- "
                f"{t['roi_counts_per_keV_kg_day_error']:.2g} counts/(keV kg day)"
            )
        click.echo(line)


@click.command("model")
@click.argument("model_file", metavar="MODEL.yaml", type=_FILE)
@click.option(
    "--data",
    "data_file",
    type=_FILE,
    help="Measured spectrum to fit (CSV bin_low_keV,bin_high_keV,counts or a ROOT file "
    "with --histogram); default: the model's data: entry.",
)
@click.option("--histogram", help="The TH1 in a ROOT --data file.")
@click.option(
    "--plot", "plot_out", type=_FILE, help="Stacked predicted spectrum (log axis, ROI shaded)."
)
@click.option(
    "--fit-plot", "fit_plot_out", type=_FILE, help="Data over the fitted model, with residuals."
)
@click.option(
    "--pseudo-data",
    "pseudo_out",
    type=_FILE,
    help="Write Poisson pseudo-data drawn from the model (CSV) and stop (nothing is fitted: "
    "not with --data).",
)
@click.option(
    "--seed",
    type=click.IntRange(min=0),
    default=1,
    show_default=True,
    help="Seed of --pseudo-data.",
)
@click.option("--json", "as_json", is_flag=True, help="Print the prediction and the fit as JSON.")
@click.option("--overwrite", is_flag=True, help="Replace existing output files.")
def model(
    model_file, data_file, histogram, plot_out, fit_plot_out, pseudo_out, seed, as_json, overwrite
) -> None:
    """Sum templates times activities into a predicted spectrum; fit the activities to data."""
    from score4.analysis.model import DataConfig, build_model, load_model, model_summary
    from score4.common.schema import input_paths

    from ..files import check_outputs

    if pseudo_out is not None and (data_file is not None or histogram is not None):
        given = "--data" if data_file is not None else "--histogram"
        raise ConfigError(
            f"{given}: --pseudo-data draws a spectrum from the model and fits nothing; "
            f"give {given} or --pseudo-data, not both"
        )
    config = load_model(model_file)
    check_outputs(
        {"--plot": plot_out, "--fit-plot": fit_plot_out, "--pseudo-data": pseudo_out},
        overwrite,
        {"the model": model_file, "the --data file": data_file, **input_paths(config)},
        images=("--plot", "--fit-plot"),
    )
    with naming_file(model_file):
        m = build_model(config)
    data_cfg: DataConfig | None
    if data_file is not None:
        data_cfg = DataConfig.model_validate({"file": data_file, "histogram": histogram})
    elif histogram is not None:
        raise ConfigError("--histogram: goes with --data FILE.root")
    else:
        data_cfg = config.data
    if fit_plot_out is not None and data_cfg is None:
        raise ConfigError("--fit-plot: needs data to fit (--data FILE or data: in the model)")
    with naming_file(model_file):
        summary = model_summary(m)
    if pseudo_out is not None:
        _write_pseudo(m, seed, pseudo_out, model_file)
        return
    fit = None
    if data_cfg is not None:
        from score4.analysis.model import fit_model, read_spectrum

        with naming_file(model_file):
            fit = fit_model(m, read_spectrum(data_cfg))
    written = _model_plots(m, fit, plot_out, fit_plot_out)
    if as_json:
        click.echo(
            json.dumps({"model": summary, "fit": None if fit is None else fit.to_dict()}, indent=2)
        )
        return
    _print_model(summary, fit, written)
    active = [
        c.name for c in m.components if c.template.normalisation.get("energy") == "active_edep"
    ]
    if active:
        click.echo(
            "  energy        active energy (targets[].activeness) in the templates of "
            f"{', '.join(active)}"
        )


def _write_pseudo(m, seed: int, out: Path, model_file: Path) -> None:
    from score4.analysis.model import pseudo_data, write_csv_spectrum

    spectrum = pseudo_data(m, seed)
    activities = ", ".join(f"{c.name} {c.activity:.6g} {c.unit}" for c in m.components)
    write_csv_spectrum(
        spectrum, out, f"pseudo-data of {model_file} (seed {seed}): Poisson counts at {activities}"
    )
    click.echo(
        f"wrote {out}: {len(spectrum.counts)} bins, {int(spectrum.counts.sum())} counts (seed "
        f"{seed})"
    )


def _model_plots(m, fit, plot_out, fit_plot_out) -> list[str]:
    written = []
    roi = None if m.config.roi is None else (m.config.roi[0] * 1e3, m.config.roi[1] * 1e3)
    if plot_out is not None:
        from score4.analysis.plots import StackComponent, plot_stacked

        layers = [
            StackComponent(f"{c.name} ({c.activity:.3g} {c.unit})", m.edges_kev, r)
            for c, r in zip(m.components, m.rates(), strict=True)
        ]
        plot_stacked(
            {m.components[0].template.detector: layers},
            plot_out,
            roi_kev=roi,
            title=f"model ({m.config.kind}):",
        )
        written.append(str(plot_out))
    if fit_plot_out is not None and fit is not None:
        from score4.analysis.plots import StackComponent, plot_fit

        layers = [
            StackComponent(
                f"{n} ({fit.activity[n]:.3g}"
                + (f" +- {fit.error[n]:.2g}" if n in fit.error else "")
                + f" {fit.units[n]})",
                fit.edges_kev,
                fit.components[k],
            )
            for k, n in enumerate(fit.names)
        ]
        plot_fit(
            fit.edges_kev,
            fit.data,
            layers,
            fit_plot_out,
            roi_kev=roi,
            title=f"fit to data, {m.components[0].template.detector} ({m.config.kind})",
        )
        written.append(str(fit_plot_out))
    return written


def _print_model(summary: dict, fit, written: list[str]) -> None:
    if written:
        click.echo(f"wrote {', '.join(written)}")
    click.echo(
        f"model: detector {summary['detector']} ({summary['kind']}), {summary['mass_kg']:.6g} kg, "
        f"live time {summary['livetime_days']:.6g} d: {summary['expected_counts']:.6g} counts "
        "expected"
    )
    for name, c in summary["components"].items():
        line = f"  {name}: {c['activity']:.6g} {c['unit']} -> {c['expected_counts']:.6g} counts"
        if "roi_counts_per_keV_kg_day" in c:
            line += f", ROI {c['roi_counts_per_keV_kg_day']:.4g} counts/(keV kg day)"
        click.echo(line)
    if fit is None:
        return
    click.echo(
        f"fit: {'valid' if fit.valid else 'NOT valid'}, deviance {fit.deviance:.4g} for "
        f"{fit.n_bins - len(fit.fitted)} degrees of freedom ({fit.n_bins} bins)"
    )
    for n in fit.names:
        err = f" +- {fit.error[n]:.3g}" if n in fit.error else " (fixed)"
        click.echo(f"  {n}: {fit.activity[n]:.6g}{err} {fit.units[n]}")
    if len(fit.fitted) > 1:
        for i, a in enumerate(fit.fitted):
            for j in range(i + 1, len(fit.fitted)):
                click.echo(f"  correlation {a} / {fit.fitted[j]}: {fit.correlation[i, j]:+.3f}")


__all__ = ["model", "template"]
