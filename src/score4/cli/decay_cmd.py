"""``score4 decay``: the radiations of a nuclide or a chain, from score4's decay data."""

from __future__ import annotations

import json
from pathlib import Path

import click

from ..errors import ConfigError
from .quiet import notice


def _seconds(text: str | None) -> float | None:
    if text is None:
        return None
    from score4.common.units import parse_quantity

    try:
        value = parse_quantity(text, "time", "--since-deposition")
    except (ConfigError, ValueError) as err:
        raise ConfigError(str(err)) from None
    if value < 0:
        raise ConfigError(f"--since-deposition: must be 0 or more, got {text!r}")
    return value * 1e-9


#: Configuration keys (in the decay chain's messages) and the options of this command.
_OPTIONS = {
    "source.decay.since_deposition": "--since-deposition",
    "source.decay.until": "--until",
    "source.decay.chain": "NUCLIDE",
}


@click.command("decay")
@click.argument("nuclide")
@click.option("--chain", is_flag=True, help="The whole chain from NUCLIDE (see --until).")
@click.option("--until", metavar="NUCLIDE", help="With --chain: stop before this nuclide.")
@click.option(
    "--since-deposition",
    metavar="TIME",
    help="With --chain: activities this long ('180 d') after pure NUCLIDE was deposited "
    "(default: secular equilibrium).",
)
@click.option(
    "--min-intensity",
    default=0.01,
    show_default=True,
    type=click.FloatRange(min=0.0),
    help="Leave out lines below this intensity (% per decay).",
)
@click.option("--json", "as_json", is_flag=True, help="Machine-readable JSON on stdout.")
@click.option(
    "--png",
    type=click.Path(dir_okay=False, path_type=Path),
    help="Draw the emitted spectra (1e6 sampled decays) into this image.",
)
@click.option("--overwrite", is_flag=True, help="Replace an existing --png file.")
def decay_command(nuclide, chain, until, since_deposition, min_intensity, as_json, png, overwrite):
    """Print the radiations of NUCLIDE per decay, like a decay-radiation table.

    NUCLIDE: Pb210, Pb-210, 210Pb, Pa234m, ... (the U-238, U-235 and Th-232 chains, K40, Co60,
    Cs137). Energies in keV (endpoint and mean for beta continua), intensities in % per decay
    (per decay of the head with --chain). Example:

        score4 decay Pb210 --chain --since-deposition "180 d"
    """
    from ..decay.table import plot_spectra, radiation_table, table_text

    if not chain and (until is not None or since_deposition is not None):
        raise ConfigError("--until and --since-deposition need --chain")
    seconds = _seconds(since_deposition)
    if png is not None:
        from ..files import check_outputs

        check_outputs({"--png": png}, overwrite, images=("--png",))
    try:
        table = radiation_table(nuclide, chain, until, seconds, min_intensity / 100.0)
    except ConfigError as err:  # name the options, not the configuration keys they stand for
        text = str(err)
        for key, option in _OPTIONS.items():
            text = text.replace(key, option)
        raise ConfigError(text) from None
    if as_json:
        click.echo(json.dumps(table, indent=1))
    else:
        click.echo(table_text(table), nl=False)
    if png is not None:
        plot_spectra(nuclide, png, chain, until, seconds)
        notice(f"wrote {png}")
