"""``score4 range``: ions into a block of material, score4's transport against TRIM's.

Like Geant4's TestEm7 and SRIM's range tables in one command: N ions at the given incidence
angle into a semi-infinite block (or a layer of ``--thickness``), the mean projected range,
longitudinal and lateral straggling, backscattered and transmitted fractions, mean exit and
deposited energy; ``--compare-srim`` runs TRIM (lunasrim) for the same case, same material
and density, and prints both with their ratio.
"""

from __future__ import annotations

import json
import math
import tempfile
from pathlib import Path

import click

from ..errors import ConfigError, Score4Error, brief
from .quiet import notice, set_quiet

# Rows of the comparison table: key, label, kind ("length" in nm, "fraction", "energy" in keV).
ROWS = (
    ("projected_range_nm", "projected range", "length"),
    ("straggling_nm", "longitudinal straggling", "length"),
    ("lateral_nm", "lateral straggling", "length"),
    ("backscattered_fraction", "backscattered fraction", "fraction"),
    ("transmitted_fraction", "transmitted fraction", "fraction"),
    ("mean_exit_energy_keV", "mean exit energy (transmitted)", "energy"),
    ("mean_deposited_keV", "mean deposited energy", "energy"),
)
# Heavy ions (Z > 2) follow TRIM trajectories up to this energy unless the run configuration
# schema says otherwise (physics.trim_max_energy).
HEAVY_ION_MAX_MEV = 1.0
ERRORS = {
    "projected_range_nm": "projected_range_err_nm",
    "straggling_nm": "straggling_err_nm",
    "lateral_nm": "lateral_err_nm",
    "backscattered_fraction": "backscattered_fraction_err",
    "transmitted_fraction": "transmitted_fraction_err",
    "mean_exit_energy_keV": "mean_exit_energy_err_keV",
}


def nist_names() -> list[str]:
    """Geant4's NIST material names (imports geant4_pybind, without physics data)."""
    from score4.inputs.materials import nist_material_names

    from ..sim.runtime import import_geant4, resolve_physics

    return nist_material_names(import_geant4(resolve_physics("auto")))


def load_materials(path: Path) -> dict:
    """The ``materials:`` section of a YAML file (other sections are not read)."""
    from pydantic import TypeAdapter, ValidationError

    from score4.common.schema import describe_validation_error
    from score4.common.yamlfile import load_yaml
    from score4.inputs.material_spec import MaterialSpec

    data = load_yaml(path, "--config") or {}
    section = data.get("materials", {}) if isinstance(data, dict) else None
    if not isinstance(section, dict):
        raise ConfigError(f"--config: {path}: materials must be a mapping of names to materials")
    try:
        adapter = TypeAdapter(dict[str, dict[str, MaterialSpec]])  # error paths: materials.X.key
        materials = adapter.validate_python({"materials": section})["materials"]
    except ValidationError as err:
        raise ConfigError(describe_validation_error(err, str(path))) from None
    from score4.inputs.materials import check_material_name

    for name in materials:  # the same naming rules as in a run configuration
        try:
            check_material_name(name)
        except ValueError as err:
            raise ConfigError(f"{path}: materials: {err}") from None
    return materials


def resolve_material(name: str, density: str | None, materials: dict, names=None) -> dict:
    """Check MATERIAL; return the ``materials`` to hand on (with a formula entry if --density).

    ``name`` is a ``materials:`` entry, a Geant4 NIST name, or a chemical formula when
    ``density`` is given.
    """
    from score4.inputs.material_spec import MaterialSpec

    if density is not None:
        if name in materials or name.startswith("G4_"):
            raise ConfigError(
                f"--density: {name!r} is a named material with its own density; --density goes "
                f"with a chemical formula such as TeO2"
            )
        from pydantic import ValidationError

        from score4.common.schema import describe_validation_error

        try:
            spec = MaterialSpec(formula=name, density=density)
        except ValidationError as err:
            message = describe_validation_error(err, "MATERIAL")
            raise ConfigError(message.replace("MATERIAL: density:", "--density:")) from None
        return {**materials, name: spec}
    if name in materials:
        return materials
    known = (names or nist_names)()
    if name in known:
        return materials
    from score4.inputs.materials import suggest_materials

    close = suggest_materials(name, list(materials) + known)
    hint = f"; closest: {', '.join(close)}" if close else ""
    raise ConfigError(
        f"MATERIAL: unknown material {name!r}{hint}; give a Geant4 NIST name (G4_Si), a name "
        f"under materials: in --config, or a chemical formula with --density"
    )


def _check_lunasrim() -> None:
    try:
        import lunasrim  # noqa: F401
    except ImportError:
        raise Score4Error(
            "--compare-srim needs the package lunasrim, which is not installed; pip install "
            "lunasrim"
        ) from None


def _finite(value):
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, dict):
        return {k: _finite(v) for k, v in value.items()}
    return value


def _fmt(value: float | None, err: float | None, kind: str, um: bool) -> str:
    if value is None or not math.isfinite(value):
        return "-"
    if kind == "fraction":
        text = f"{value:.4f}"
        return text + (f" +- {err:.4f}" if err is not None and math.isfinite(err) else "")
    if kind == "length":
        scale, unit = (1e-3, "um") if um else (1.0, "nm")
        text = f"{value * scale:.4g}"
        if err is not None and math.isfinite(err):
            text += f" +- {err * scale:.2g}"
        return f"{text} {unit}"
    text = f"{value:.5g}"
    if err is not None and math.isfinite(err):
        text += f" +- {err:.2g}"
    return f"{text} keV"


def _ratio(a, b) -> str:
    if a is None or b is None or not (math.isfinite(a) and math.isfinite(b)) or b == 0:
        return "-"
    return f"{a / b:.3f}"


def format_table(result: dict) -> str:
    """The readable report: score4 | SRIM | ratio, one row per quantity."""
    s4, srim = result["score4"], result.get("srim")
    um = (s4.get("projected_range_nm") or 0) > 1e4
    where = (
        "semi-infinite block"
        if result["thickness_nm"] is None
        else f"layer of {result['thickness_nm']:.6g} nm"
    )
    angle = result["angle_deg"]
    lines = [
        f"{result['ion']} {result['energy_keV']:.6g} keV into {result['material']} "
        f"({result['formula']}, {result['density_g_cm3']:.6g} g/cm3), {where}, "
        + ("normal incidence" if angle == 0 else f"{angle:g} deg from the normal"),
    ]
    head = f"  {'':32s}{'score4':>24s}"
    if srim is not None:
        head += f"{'SRIM (TRIM)':>24s}{'ratio':>8s}"
    lines.append(head)
    for key, label, kind in ROWS:
        err = ERRORS.get(key)
        row = f"  {label:32s}{_fmt(s4.get(key), s4.get(err), kind, um):>24s}"
        if srim is not None:
            row += f"{_fmt(srim.get(key), srim.get(err), kind, um):>24s}"
            row += f"{_ratio(s4.get(key), srim.get(key)):>8s}"
        lines.append(row)
    counts = f"{s4['events']} ({s4['stopped']})"
    row = f"  {'ions (stopped)':32s}{counts:>24s}"
    if srim is not None:
        counts = f"{srim['events']} ({srim['stopped']})"
        row += f"{counts:>24s}"
    lines.append(row)
    table = (srim or {}).get("table")
    if table:
        lines.append(
            "  SRIM range table (analytic): projected range "
            f"{_fmt(table['projected_range_nm'], None, 'length', um)}, "
            f"straggling {_fmt(table['straggling_nm'], None, 'length', um)}, "
            f"lateral {_fmt(table['lateral_nm'], None, 'length', um)}"
        )
    lines.append(
        "  (+- : standard error of the mean or binomial error; straggling as TRIM defines it: "
        "rms about the mean depth, lateral rms about the beam axis)"
    )
    return "\n".join(lines)


@click.command("range", context_settings={"ignore_unknown_options": True})  # ENERGY "-5 keV"
@click.argument("ion")
@click.argument("energy")
@click.argument("material")
@click.option(
    "--events", "-n", default="1000", metavar="N", show_default=True, help="Ions to simulate."
)
@click.option(
    "--seed",
    default="1",
    metavar="S",
    show_default=True,
    help="Random seed; score4's TRIM libraries and the TRIM reference draw their own seeds from "
    "it.",
)
@click.option(
    "--thickness",
    metavar="L",
    help="A layer of this thickness ('20 nm') instead of a semi-infinite block.",
)
@click.option(
    "--angle",
    default="0",
    metavar="DEG",
    show_default=True,
    help="Incidence angle from the normal, degrees.",
)
@click.option(
    "--density", metavar="RHO", help="Density ('6.02 g/cm3') when MATERIAL is a chemical formula."
)
@click.option(
    "--config",
    "config_file",
    type=click.Path(dir_okay=False, path_type=Path),
    help="YAML file whose materials: section defines MATERIAL.",
)
@click.option("--json", "as_json", is_flag=True, help="Machine-readable JSON on stdout.")
@click.option("--compare-srim", is_flag=True, help="Also run TRIM (lunasrim) and compare.")
@click.option(
    "--srim-events",
    default=None,
    metavar="N",
    help="TRIM ions for --compare-srim (default: --events).",
)
@click.option(
    "--png",
    type=click.Path(dir_okay=False, path_type=Path),
    help="Draw the depth distributions (score4 and, with --compare-srim, TRIM) into this image.",
)
@click.option("--overwrite", is_flag=True, help="Replace an existing --png file.")
@click.option(
    "--alphas",
    type=click.Choice(["geant4", "trim"]),
    default="geant4",
    show_default=True,
    help="How score4 moves alphas (physics.alphas): Geant4, or TRIM trajectories.",
)
@click.option(
    "--quiet", "-q", is_flag=True, help="No progress messages on stderr (as score4 -q range)."
)
def range_command(
    ion,
    energy,
    material,
    events,
    seed,
    thickness,
    angle,
    density,
    config_file,
    as_json,
    compare_srim,
    srim_events,
    png,
    overwrite,
    alphas,
    quiet,
) -> None:
    """Send ION of ENERGY ('103 keV') into MATERIAL and report how far it goes.

    ION: Pb206, Pb-206, alpha, He4, ... MATERIAL: a Geant4 NIST name (G4_Si), a name under
    materials: in --config, or a chemical formula with --density. Example:

        score4 range Pb206 "103 keV" G4_Si --compare-srim
    """
    species, energy_mev, n_events, n_srim, seed_value, thickness_mm, angle_deg = parse_case(
        ion, energy, events, srim_events, seed, thickness, angle, compare_srim
    )
    if png is not None:
        from ..files import check_outputs

        check_outputs({"--png": png}, overwrite, {"the --config file": config_file}, ("--png",))
    materials = load_materials(config_file) if config_file is not None else {}
    materials = resolve_material(material, density, materials)

    if quiet:
        set_quiet(click.get_current_context())
    echo = notice

    result = run_range(
        species,
        energy_mev,
        material,
        n_events,
        seed_value,
        thickness_mm,
        angle_deg,
        materials,
        n_srim if compare_srim else None,
        echo,
        alphas,
    )
    if png is not None:
        from score4.analysis.plots import plot_range_depths

        samples = {"score4": result.pop("_score4_sample")}
        if "_srim_sample" in result:
            samples["TRIM (lunasrim)"] = result.pop("_srim_sample")
        title = f"{species.label} {energy_mev * 1e3:.6g} keV in {material}" + (
            f", {angle_deg:g} deg" if angle_deg else ""
        )
        plot_range_depths(samples, png, title)
        echo(f"wrote {png}")
    result.pop("_score4_sample", None)
    result.pop("_srim_sample", None)
    if as_json:
        click.echo(json.dumps(_finite(result), indent=2))
    else:
        click.echo(format_table(result))


def parse_case(ion, energy, events, srim_events, seed, thickness, angle, compare_srim):
    """Check the command's arguments; return (species, MeV, events, TRIM ions, seed, mm, deg).

    Raises :class:`ConfigError` (one line naming the argument) for anything out of range,
    before any simulation starts.
    """
    from score4.common.schema import quantity

    from ..ions.species import parse_ion

    species = parse_ion(ion, "ION")
    energy_mev = quantity(energy, "energy", "ENERGY", positive=True)
    n_events = _positive_int(events, "--events")
    n_srim = _positive_int(srim_events, "--srim-events") if srim_events is not None else n_events
    seed_value = _int(seed, "--seed")
    if not 0 <= seed_value < 2147483563:
        raise ConfigError(f"--seed: must be in [0, 2147483562], got {seed!r}")
    thickness_mm = None
    if thickness is not None:
        thickness_mm = quantity(thickness, "length", "--thickness", positive=True)
    try:
        angle_deg = float(str(angle).removesuffix("deg").strip())
    except ValueError:
        raise ConfigError(f"--angle: expected degrees such as 60, got {angle!r}") from None
    if not 0 <= angle_deg <= 89.99:
        raise ConfigError(
            f"--angle: the incidence angle from the normal must be >= 0 and <= 89.99 degrees, "
            f"got {angle!r}"
        )
    check_model_energy(species, energy_mev)
    if compare_srim:
        _check_lunasrim()
        from ..ions.srim_reference import SRIM_MAX_Z, check_srim_energy

        if species.z > SRIM_MAX_Z:
            raise ConfigError(
                f"ION: {species.label} has Z = {species.z}; SRIM/TRIM knows ions up to Z = 92"
            )
        try:
            check_srim_energy(species, energy_mev)
        except ConfigError as err:
            raise ConfigError(f"ENERGY: {str(err).removeprefix('energy: ')}") from None
    return species, energy_mev, n_events, n_srim, seed_value, thickness_mm, angle_deg


def heavy_ion_limit_mev() -> float:
    """Energy up to which ions with Z > 2 follow TRIM trajectories in score4 (MeV)."""
    from score4.inputs.config import PhysicsConfig

    field = PhysicsConfig.model_fields.get("trim_max_energy")
    return float(field.default) if field is not None else HEAVY_ION_MAX_MEV


def check_model_energy(species, energy_mev: float) -> None:
    """Refuse energies outside score4's validated ion transport (heavy ions: TRIM replay)."""
    if species.z > 2:
        limit = heavy_ion_limit_mev()
        if energy_mev > limit:
            raise ConfigError(
                f"ENERGY: {energy_mev:g} MeV is above the validity of score4's heavy-ion model for "
                f"{species.label}: ions with Z > 2 follow TRIM trajectories up to {limit:g} MeV "
                f"(physics.trim_max_energy); above it Geant4's ion transport, which ranges slow "
                f"heavy ions wrongly, would be used"
            )


def _int(text, option: str) -> int:
    from score4.common.units import parse_count

    try:
        return parse_count(text)
    except ConfigError:
        raise ConfigError(f"{option}: expected an integer, got {brief(text)}") from None


def _positive_int(text, option: str) -> int:
    from score4.common import limits

    value = _int(text, option)
    if value <= 0:
        raise ConfigError(f"{option}: must be >= 1, got {brief(text)}")
    problem = limits.too_many_events(value)
    if problem:
        raise ConfigError(f"{option}: {problem}")
    # every event keeps its end point and deposits in memory (~200 bytes)
    limits.check_memory(200 * value, f"{value} events", option)
    return value


def _quarters(echo):
    """A progress callback that reports at 25 %, 50 %, 75 % and 100 %."""
    shown = [0]

    def progress(done: int, total: int) -> None:
        quarter = 4 * done // total
        if quarter > shown[0]:
            shown[0] = quarter
            echo(f"  TRIM {done}/{total} ions")

    return progress


def run_range(
    species,
    energy_mev: float,
    material: str,
    events: int,
    seed: int,
    thickness_mm: float | None,
    angle_deg: float,
    materials: dict,
    srim_events: int | None,
    echo,
    alphas: str = "geant4",
) -> dict:
    """Run score4 (and TRIM if ``srim_events``); the result dict of ``--json``.

    Keys: ``ion``, ``energy_keV``, ``material``, ``formula``, ``density_g_cm3``,
    ``thickness_nm`` (None: semi-infinite), ``angle_deg``, ``seed``, ``score4`` (the
    :func:`~score4.ions.srim_reference.summarize` keys), the same keys at the top level, and
    ``srim`` (same keys plus ``table``: SRIM's analytic range table, semi-infinite normal
    incidence only) when compared. ``_score4_sample``/``_srim_sample`` hold the samples.
    """
    from ..ions.srim_reference import summarize

    try:
        from ..sim.range_run import simulate_range
    except ImportError as err:
        raise Score4Error(
            f"score4 range: score4's ion-range simulation (score4.sim.range_run) is not available "
            f"in this installation ({err})"
        ) from None
    echo(f"score4: {events} {species.label} ions of {energy_mev * 1e3:.6g} keV into {material} ...")
    from ..sim.runtime import redirect_native_output

    with tempfile.TemporaryDirectory() as tmp:
        log = Path(tmp) / "geant4.log"
        with redirect_native_output(log):  # keep Geant4's console off stdout (--json)
            sample, composition = simulate_range(
                species.name,
                energy_mev,
                material,
                events,
                seed,
                thickness_mm=thickness_mm,
                angle_deg=angle_deg,
                materials=materials or None,
                alphas=alphas,
            )
    s4 = summarize(sample)
    result = {
        "ion": species.label,
        "energy_keV": energy_mev * 1e3,
        "material": material,
        "formula": composition.formula,
        "composition": dict(composition.atoms),
        "density_g_cm3": composition.density,
        "thickness_nm": None if thickness_mm is None else thickness_mm * 1e6,
        "angle_deg": angle_deg,
        "seed": seed,
        **s4,
        "score4": s4,
        "_score4_sample": sample,
    }
    if srim_events is not None:
        from score4.runner.seeds import reference_trim_seed

        from ..ions.srim_reference import srim_range_sample, stopping_table_reference

        # never the seed of score4's own trajectory libraries: an independent TRIM run
        trim_seed = reference_trim_seed(seed)
        echo(f"TRIM (lunasrim): {srim_events} ions, TRIM seed {trim_seed} ...")
        srim_sample = srim_range_sample(
            species,
            energy_mev,
            composition,
            srim_events,
            trim_seed,
            thickness_mm=thickness_mm,
            angle_deg=angle_deg,
            progress=_quarters(echo),
        )
        srim = summarize(srim_sample)
        srim["trim_seed"] = trim_seed
        if thickness_mm is None and angle_deg == 0:
            srim["table"] = stopping_table_reference(species, energy_mev, composition)
        result["srim"] = srim
        result["_srim_sample"] = srim_sample
    return result
