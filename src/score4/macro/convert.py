"""Building the score4 run configuration from the collected commands: spike surfaces, the rough
face (patch, portal tiling), the target, the source (particle, energy, depth table) and the run;
:func:`import_macro` runs the whole conversion.
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

from score4.common.units import parse_quantity
from score4.inputs.config import parse_config

from ..errors import ConfigError
from .collect import Helper, State, collect
from .reader import G4_LENGTH, Quantity, number_text, read_macro
from .report import ImportReport
from .tables import DEFAULT_DESCRIBER_WIDTH, DEFAULT_STEP_FRACTION, DESCRIBER_DEFAULTS, SPIKEFORMS

#: Name, thickness and material of the target block filled in under the rough face.
DEFAULT_TARGET = "target"
DEFAULT_TARGET_THICKNESS = "1 mm"
DEFAULT_MATERIAL = "G4_Si"
#: Relative tolerance of the size rules (the original compares to an absolute 2e-15 mm).
_RTOL = 1e-9


def _close(a: float, b: float) -> bool:
    return abs(a - b) <= _RTOL * max(abs(a), abs(b))


def _spike_surface(state: State, helper: Helper, label: str, defaults: dict | None) -> dict:
    """The ``kind: spikes`` description of a helper (``defaults``: values of unset parameters)."""
    values = helper.values

    def value(param: str):
        if param in values:
            return values[param][0]
        if defaults is not None:
            return defaults[param]
        what = {
            "dx": "setSpikeDx",
            "dy": "setSpikeDy",
            "mean": "setSpikeMeanHeight",
            "nx": "setSpikesNx",
            "ny": "setSpikesNy",
        }[param]
        raise ConfigError(
            f"{state.macro}: {label}/{what} is missing; the original's default 0 builds no spike, "
            "so score4 cannot guess it"
        )

    def q(param: str) -> Quantity:
        v = value(param)
        if isinstance(v, Quantity):
            return v
        number, unit = v.split()
        return Quantity(float(number), unit, float(number) * G4_LENGTH[unit], "length")

    key = f"surfaces.{helper.name}"
    form = value("form") if "form" in values or defaults is not None else "StandardPyramid"
    shape = SPIKEFORMS[form]
    pyramid = shape == "pyramid"
    # Spike.cc: a pyramid is one G4Trd with half-height dz = MeanHeight centred at z = MeanHeight,
    # so it spans z = 0 .. 2 MeanHeight: full height = 2 x MeanHeight (and the Gaussian sigma of
    # UniformPyramid, drawn on MeanHeight, doubles with it). Bump and Peak stack nLayer layers of
    # height MeanHeight / nLayer: full height = 1 x MeanHeight.
    factor = 2.0 if pyramid else 1.0
    dx, dy, mean = q("dx"), q("dy"), q("mean")
    nx, ny = value("nx"), value("ny")
    spec: dict[str, Any] = {
        "kind": "spikes",
        "nx": nx,
        "ny": ny,
        "width_x": dx.text(2),
        "width_y": dy.text(2),
        "height": mean.text(factor),
        "shape": shape,
    }
    detail = {
        "dx": f"{key}.width_x = {dx.text(2)} (2 x half-width)",
        "dy": f"{key}.width_y = {dy.text(2)} (2 x half-width)",
        "mean": f"{key}.height = {mean.text(factor)} ({'2 x' if pyramid else '1 x'} "
        f"setSpikeMeanHeight: {form} "
        + ("is a G4Trd of half-height MeanHeight)" if pyramid else "layers add up to MeanHeight)"),
        "nx": f"{key}.nx = {nx}",
        "ny": f"{key}.ny = {ny}",
        "form": f"{key}.shape = {shape}"
        + (" (Gaussian heights: height_sigma)" if form == "UniformPyramid" else ""),
        "material": f"targets.0.material = {helper.get('material')} (the rough layer is in its "
        "target's material)",
    }
    reasons: dict[str, str] = {}
    if form == "UniformPyramid":
        dev = q("dev") if "dev" in values or defaults is not None else None
        if dev is not None and dev.value > 0:
            spec["height_sigma"] = dev.text(factor)
            spec["seed"] = 0
            state.default(
                f"{key}.seed",
                "0 (the original draws the spike heights from Geant4's "
                "engine; score4 draws them with numpy from this seed)",
            )
            state.report.notes.append(
                f"{key}: the original clamps Gaussian heights <= 0 to 1e-9 mm (and then aborts in "
                "G4Trd); score4 redraws heights below min_height (default 1 % of the mean), a "
                "truncated Gaussian"
            )
        if dev is not None:
            detail["dev"] = f"{key}.height_sigma = {dev.text(factor)} (2 x, like the height)"
    else:
        reasons["dev"] = (
            f"the original uses the deviation only for UniformPyramid; {form} spikes all have the "
            "mean height"
        )
    if pyramid:
        reasons["nlayer"] = "the original builds pyramids from one G4Trd whatever setNLayer says"
    else:
        spec["n_layers"] = value("nlayer") if "nlayer" in values or defaults is not None else 1
        detail["nlayer"] = f"{key}.n_layers = {spec['n_layers']}"
    if not (_close(dx.value, dy.value)):
        state.report.notes.append(
            f"{key}: spike half-widths differ in x and y ({dx.text()} and {dy.text()}); the "
            "original's RectangleDivider breaks such grids (notes §3.1-1), score4 builds them as "
            "written"
        )
    for param, (_, cmd) in values.items():
        if param in reasons:
            state.ignored(cmd, reasons[param])
        elif param in detail:
            state.converted(cmd, detail[param])
    for param, _, cmd in helper.commands:  # earlier values of repeated commands
        if values[param][1] is not cmd:
            state.ignored(cmd, f"overridden by {state.where(values[param][1])}")
    return spec


def _patch_basis(
    state: State, helper: Helper, one_patch: bool
) -> tuple[Quantity, Quantity, Quantity | None]:
    """Check a helper's basis against its spikes (RoughnessHelper::CheckValues).

    Returns the patch half-sizes along x and y and the basis half-height (None if not given).
    ``one_patch``: the face is this single patch (no portal), so the basis sets the face size.
    """
    key = f"surfaces.{helper.name}"
    halves = []
    for i, axis in enumerate(("x", "y")):
        spike, n = helper.get(f"d{axis}"), helper.get(f"n{axis}")
        want = Quantity(spike.number * n, spike.unit, spike.value * n, "length")
        basis_cmd = helper.cmd(f"basis_d{axis}")
        if basis_cmd is None:
            state.default(
                f"{key}: patch size along {axis}",
                f"{want.text(2)} = setSpikesN{axis} x 2 x "
                f"setSpikeD{axis} (no setBasisD{axis}; the only value the original accepts)",
            )
            halves.append(want)
            continue
        basis = helper.get(f"basis_d{axis}")
        if not _close(basis.value, want.value):
            raise basis_cmd.fail(
                f"basis half-length {basis.text()} must equal setSpikesN{axis} x setSpikeD{axis} = "
                f"{n} x {spike.text()} = {want.text()} (the original exits on this: "
                "RoughnessHelper::CheckValues)"
            )
        where = (
            f"targets.0.size.{i} = {basis.text(2)}"
            if one_patch
            else f"patch size {basis.text(2)} along {axis}"
        )
        state.converted(basis_cmd, f"{where} (2 x half-length; = {key}.n{axis} x width_{axis})")
        halves.append(basis)
    return halves[0], halves[1], helper.get("basis_dz")


def _portal_face(
    state: State, portal: Helper, patch: tuple[Quantity, Quantity], config: dict, rough: dict
) -> tuple[str, str]:
    """Face size from the portal (checked like MultiportalHelper::CheckValues), converted keys."""
    sizes = []
    for axis, half_patch in zip(("x", "y"), patch, strict=True):
        sub = portal.get(f"sub_d{axis}")
        if sub is not None:
            sub_cmd = portal.set_cmd(f"sub_d{axis}")
            if not _close(sub.value, half_patch.value):
                raise sub_cmd.fail(
                    f"subworld half-size {sub.text()} differs from the roughness patch half-size "
                    f"{half_patch.text()}; score4 tiles patches edge to edge and cannot leave gaps "
                    "or overlaps between them"
                )
            state.converted(
                sub_cmd,
                f"patch size {sub.text(2)} along {axis} (2 x half-length, = the roughness patch)",
            )
        n, n_cmd = portal.get(f"n{axis}"), portal.cmd(f"n{axis}")
        full = portal.get(f"d{axis}")
        if full is None:
            if n is None:
                raise ConfigError(
                    f"{state.macro}: MultiportalHelper {portal.name!r}: give setD{axis}Portal or "
                    f"setN{axis}Subworld: the face size along {axis} is unknown"
                )
            full = Quantity(half_patch.number * n, half_patch.unit, half_patch.value * n, "length")
            state.default(
                f"face size along {axis}",
                f"{full.text(2)} = setN{axis}Subworld x patch size (no setD{axis}Portal)",
            )
        else:
            full_cmd = portal.set_cmd(f"d{axis}")
            ratio = full.value / half_patch.value
            if not _close(ratio, round(ratio)) or round(ratio) < 1:
                raise full_cmd.fail(
                    f"portal half-size {full.text()} is not a whole number of patch half-sizes "
                    f"({half_patch.text()}): {ratio:.6g}"
                )
            if n is not None and n != round(ratio):
                raise portal.set_cmd(f"n{axis}").fail(
                    f"{n} subworlds x {half_patch.text()} != portal half-size {full.text()} (the "
                    "original exits on this: MultiportalHelper::CheckValues)"
                )
            state.converted(
                full_cmd,
                f"targets.0.size.{'xy'.index(axis)} = {full.text(2)} (2 x half-length: the face)",
            )
        if n_cmd is not None:
            state.converted(n_cmd, f"{n} patches along {axis} (= face size / patch size)")
        sizes.append(full.text(2))
    dz, dz_cmd = portal.get("dz"), portal.cmd("dz")
    sub_dz, sub_dz_cmd = portal.get("sub_dz"), portal.cmd("sub_dz")
    if dz is not None and sub_dz is not None and not _close(dz.value, sub_dz.value):
        raise portal.set_cmd("sub_dz").fail(
            f"subworld half-height {sub_dz.text()} != portal half-height {dz.text()} (the original "
            "exits on this: MultiportalHelper::CheckValues)"
        )
    for c in (dz_cmd, sub_dz_cmd):
        if c is not None:
            state.ignored(
                c, "score4 sizes the rough layer's envelope itself (base_thickness + tallest spike)"
            )
    material_cmd = portal.cmd("material")
    if material_cmd is not None:
        config.setdefault("world", {})["material"] = portal.get("material")
        state.converted(
            material_cmd,
            f"world.material = {portal.get('material')} (the medium around "
            "the patches: score4's layer envelope is of the world material)",
        )
        state.report.notes.append(
            f"deviation: the original gives {portal.get('material')} ({state.where(material_cmd)}) "
            "to the portal, its subworlds and triggers only; score4 has no separate portal "
            "volume and sets the whole world's material, so the medium outside the portal "
            "changes too"
        )
    for param, _, cmd in portal.commands:
        if portal.values[param][1] is not cmd:
            state.ignored(cmd, f"overridden by {state.where(portal.values[param][1])}")
    rough["tiling"] = "portal"
    return sizes[0], sizes[1]


def _relative(path: Path, folder: Path) -> str:
    """``path`` relative to ``folder`` (how score4 resolves config paths), or absolute if they share
    only the root."""
    path, folder = path.resolve(), folder.resolve()
    try:
        common = Path(os.path.commonpath([path, folder]))
    except ValueError:  # another drive (Windows)
        return str(path)
    return str(path) if common.parent == common else os.path.relpath(path, folder)


def _depth(state: State, out_dir: Path, stem: str) -> dict | None:
    """``source.depth`` from the /shift/ commands, or None (vertices on the surface)."""
    from ..source.sampling import read_table

    mn, mx = state.settings.get("depth_min"), state.settings.get("depth_max")
    if not state.tables:
        for entry in (mn, mx):
            if entry is not None:
                state.ignored(
                    entry[1],
                    "no /shift/loadShiftTable: the original does not shift without a table",
                )
        return None
    depth: dict[str, Any] = {"profile": "table"}
    if len(state.tables) == 1:
        table, cmd = state.tables[0]
        try:
            depths, _ = read_table(table, "length", unit="nm", what="shift table", xname="depth")
        except ConfigError as err:
            raise cmd.fail(
                f"{err} (score4 reads the original's 'depth,weight' rows in nm)"
            ) from None
        depth["file"] = _relative(table, out_dir)
        depth["unit"] = "nm"
        state.converted(cmd, f"source.depth: profile table, file {depth['file']}, unit nm")
    else:
        # The original appends each table to the previous ones (PointShift::LoadShiftTable).
        rows = []
        for table, cmd in state.tables:
            try:
                rows.append(
                    f"# from {table} ({state.where(cmd)})\n" + table.read_text().rstrip("\n") + "\n"
                )
            except (OSError, UnicodeDecodeError) as err:
                raise cmd.fail(f"cannot read {str(table)!r} ({err})") from None
        name = f"{stem}.depth.txt"
        text = (
            f"# depth table merged by score4 import-macro from {len(rows)} /shift/loadShiftTable "
            "files,\n# in the order the original appends them; columns: depth, weight\n# unit: "
            "nm\n" + "".join(rows)
        )
        with tempfile.TemporaryDirectory() as folder:
            check = Path(folder) / name
            check.write_text(text)
            try:
                depths, _ = read_table(check, "length", what="merged shift table", xname="depth")
            except ConfigError as err:
                raise state.tables[1][1].fail(
                    f"the tables cannot be merged as the original appends them: "
                    f"{str(err).replace(str(check), name)}"
                ) from None
        state.report.files[name] = text
        depth["file"] = name
        for _, cmd in state.tables:
            state.converted(cmd, f"source.depth: profile table, merged into {name}")
        state.report.notes.append(
            f"the original appends every loaded table to the previous ones; {name} holds them "
            "merged in that order"
        )
    steps = np.diff(depths)
    if len(steps) and not all(_close(s, steps[0]) for s in steps):
        state.report.notes.append(
            "the shift table's depths are not equally spaced: the original weights its bins "
            "without their widths (notes §3.1-16), score4 samples the true piecewise-linear "
            "density through the points, so the two differ"
        )
    if mn is not None and mx is not None and mx[0].value <= mn[0].value:
        raise mx[1].fail(
            f"the maximum shift {mx[0].text()} must be larger than the minimum {mn[0].text()} "
            f"({state.where(mn[1])})"
        )
    for key, entry in (("min", mn), ("max", mx)):
        if entry is not None:
            depth[key] = entry[0].text()
            state.converted(entry[1], f"source.depth.{key} = {entry[0].text()}")
    depth["definition"] = "normal"
    state.report.notes.append(
        "the original applies /shift/ settings only when its C++ builds the sampler with a shift "
        "file (notes §3.1-17); score4 applies them"
    )
    return depth


def _source(
    state: State, config: dict, target: str, material: str, out_dir: Path, stem: str
) -> None:
    s = state.settings
    source: dict[str, Any] = {"surface": {"volume": target, "face": "+z"}}
    state.default(
        "source.surface",
        f"{{volume: {target}, face: +z}} (the original samples the "
        "rough surface; score4 names the face it covers)",
    )
    particle = s.get("particle")
    energy = s.get("energy")
    if particle is None:
        source["particle"] = "geantino"
        state.default("source.particle", "geantino (GPS default; the macro has no /gps/particle)")
    elif particle[0] == "ion":
        ion = s.get("ion")
        if ion is None:
            raise particle[1].fail("'ion' needs /gps/ion Z A to say which ion")
        from ..elements import ELEMENTS

        z, a = ion[0]
        if z > len(ELEMENTS) or a < z:
            raise ion[1].fail(f"no nuclide with Z = {z} and A = {a}")
        nuclide = f"{ELEMENTS[z - 1]}{a}"
        if energy is not None and energy[0].value == 0:
            source["nuclide"] = nuclide
            state.converted(
                particle[1],
                f"source.nuclide = {nuclide} (with /gps/ion; an ion at rest decays: "
                "Geant4 radioactive decay, needs full physics)",
            )
            state.converted(ion[1], f"source.nuclide = {nuclide}")
            state.converted(energy[1], "energy 0: the ion is at rest (source.nuclide)")
            energy = None
        else:
            source["particle"] = nuclide
            state.converted(particle[1], f"source.particle = {nuclide} (with /gps/ion)")
            state.converted(ion[1], f"source.particle = {nuclide}")
    else:
        source["particle"] = particle[0]
        state.converted(particle[1], f"source.particle = {particle[0]}")
        if s.get("ion") is not None:
            state.ignored(s["ion"][1], f"/gps/particle is {particle[0]}, not ion")
    if "particle" in source:
        if energy is None:
            source["energy"] = "1 MeV"
            state.default("source.energy", "1 MeV (GPS default; the macro sets no energy)")
        elif energy[0].value == 0:
            raise energy[1].fail("score4 needs a positive energy for a particle source")
        else:
            source["energy"] = energy[0].text()
            state.converted(energy[1], f"source.energy = {energy[0].text()}")
    direction = s.get("direction")
    source["direction"] = "isotropic"
    if direction is None:
        state.default(
            "source.direction",
            "isotropic (the macro has no /gps/ang/type; GPS's own default is one fixed direction)",
        )
    else:
        state.converted(direction[1], "source.direction = isotropic")
    depth = _depth(state, out_dir, stem)
    if depth is not None:
        source["depth"] = depth
        confine = s.get("confine")
        if confine is None:
            state.default(
                "source.confine",
                "true (score4 keeps shifted vertices in the target's "
                "material; the original confines only with /shift/confineToMaterial)",
            )
        else:
            if confine[0] != material:
                raise confine[1].fail(
                    f"no converted volume is made of {confine[0]!r}: the target is {material}"
                )
            source["confine"] = confine[0]
            state.converted(confine[1], f"source.confine = {confine[0]}")
    elif s.get("confine") is not None:
        state.ignored(s["confine"][1], "no /shift/loadShiftTable: vertices stay on the surface")
    config["source"] = source


def _run(state: State, config: dict) -> None:
    run: dict[str, Any] = {}
    if state.beam_on:
        run["events"] = sum(n for n, _ in state.beam_on)
        for _, cmd in state.beam_on:
            state.converted(
                cmd,
                f"run.events = {run['events']}"
                + (f" (sum of {len(state.beam_on)} runs)" if len(state.beam_on) > 1 else ""),
            )
        if len(state.beam_on) > 1:
            state.report.notes.append(
                f"{len(state.beam_on)} /run/beamOn commands: one score4 run of all their events"
            )
        if run["events"] < 1:
            raise state.beam_on[-1][1].fail("no events: score4 needs run.events >= 1")
    else:
        run["events"] = 1000
        state.default("run.events", "1000 (score4's default; the macro has no /run/beamOn)")
    seeds = state.settings.get("seeds")
    if seeds is None:
        run["seed"] = 1
        state.default("run.seed", "1 (score4's default; the macro has no /random/setSeeds)")
    else:
        values, cmd = seeds
        seed = 0
        for v in values:  # one seed as it is; several folded into one 63-bit number
            seed = (seed * 2**32 + v) % 2**63
        run["seed"] = seed
        how = (
            ""
            if len(values) == 1
            else f" (= {' x 2^32 + '.join(map(str, values))}, folded: score4 takes one seed)"
        )
        state.converted(cmd, f"run.seed = {seed}{how}")
    config["run"] = run
    cut = state.settings.get("cut")
    if cut is not None:
        config["physics"] = {"production_cut": cut[0].text()}
        state.converted(cut[1], f"physics.production_cut = {cut[0].text()}")


def _surfaces(state: State) -> list[Helper]:
    """The helpers that describe surfaces: the RoughnessHelpers, else the Describer
    (/geometry/surface)."""
    if state.rough:
        for _, _, cmd in state.describer.commands:
            state.ignored(
                cmd,
                "overridden: RoughnessHelper copies its own parameters into the Describer "
                "(RoughnessHelper::BuildSurface)",
            )
        return list(state.rough.values())
    if state.describer.commands:
        state.default(
            "surfaces.surface",
            "unset /geometry/surface values take the Describer's "
            "defaults (half-width 0.005 mm, 1 x 1 spikes, mean height 0.005 mm, sigma 1 mm)",
        )
        return [state.describer]
    raise ConfigError(
        f"{state.macro}: no rough surface: the macro has no /Surface/RoughnessHelper/... or "
        "/geometry/surface/... commands, so there is nothing to convert"
    )


def _face(state: State, helpers: list[Helper], config: dict) -> tuple[dict, str, str]:
    """The rough face (``targets.0.rough.0``) and the face size along x and y."""
    first = helpers[0]
    portals = list(state.portals.values())
    placed = helpers if portals else helpers[:1]
    rough: dict[str, Any] = {"face": "+z"}
    state.default("targets.0.rough.0.face", "+z (spikes point along +z in the original's patch)")
    if first is state.describer:
        patch = []
        for axis in ("x", "y"):
            n = first.get(f"n{axis}", DESCRIBER_DEFAULTS[f"n{axis}"])
            half = first.get(f"d{axis}") or DEFAULT_DESCRIBER_WIDTH
            patch.append(Quantity(half.number * n, half.unit, half.value * n, "length"))
        base = None
    else:
        bases = {h.name: _patch_basis(state, h, one_patch=not portals) for h in helpers}
        *patch, base = bases[first.name]
        for h in placed[1:]:  # variants of one face: one patch size, one base thickness
            *other, other_base = bases[h.name]
            for axis, a, b in zip(("x", "y"), patch, other, strict=True):
                if not _close(a.value, b.value):
                    raise h.set_cmd(f"d{axis}").fail(
                        f"the patch of {h.name!r} is {2 * b.value:g} mm along {axis}, that of "
                        f"{first.name!r} {2 * a.value:g} mm; the patches of one face must have one "
                        "size"
                    )
            mismatch = (
                (base is None) != (other_base is None)
                if base is None or other_base is None
                else not _close(base.value, other_base.value)
            )
            if mismatch:
                c = h.cmd("basis_dz") or first.set_cmd("basis_dz")
                raise c.fail(
                    f"{h.name!r} and {first.name!r} have different basis heights; a score4 rough "
                    "face has one base_thickness"
                )
    if base is not None:
        rough["base_thickness"] = base.text(2)
        for h in helpers:
            basis_cmd = h.cmd("basis_dz")
            if basis_cmd is not None:
                state.converted(
                    basis_cmd,
                    f"targets.0.rough.0.base_thickness = {base.text(2)} (2 x half-height)",
                )
    else:
        state.default(
            "targets.0.rough.0.base_thickness",
            "1 um (score4's default; the macro gives no basis height)",
        )
    for extra in portals[1:]:
        for _, _, cmd in extra.commands:
            state.unknown(
                cmd,
                f"a second MultiportalHelper ({extra.name!r}): score4 converts one portal per "
                "macro",
            )
    if portals:
        size_x, size_y = _portal_face(state, portals[0], (patch[0], patch[1]), config, rough)
    else:
        size_x, size_y = patch[0].text(2), patch[1].text(2)
        state.report.notes.append(
            "no MultiportalHelper: the face is one patch (targets.0.size = the patch size)"
        )
    if len(placed) > 1:
        rough["variants"] = [
            {"surface": h.name, "density": round(1 / len(placed), 12)} for h in placed
        ]
        rough["fill"] = "exact"
        state.default(
            "targets.0.rough.0.variants",
            f"{len(placed)} patches with equal densities "
            "(the original sets them in C++, AddSubworldDensity; edit them here)",
        )
        state.default(
            "targets.0.rough.0.fill",
            "exact (the realised fractions equal the densities; "
            "the original draws each cell independently, like fill: random)",
        )
    else:
        rough["surface"] = first.name
    if len(helpers) > len(placed):
        state.report.notes.append(
            f"several RoughnessHelpers and no portal: only {first.name!r} is placed; "
            f"{', '.join(h.name for h in helpers[1:])} are defined under surfaces (the "
            "original places them in C++)"
        )
    order = ("face", "surface", "variants", "fill", "tiling", "base_thickness")
    return {k: rough[k] for k in order if k in rough}, size_x, size_y


def _material(state: State, placed: list[Helper]) -> str:
    """The target material: the placed patches' one material (a score4 layer is in its target's)."""
    given = {h.name: h.get("material") for h in placed if h.get("material") is not None}
    if len(set(given.values())) > 1:
        names = ", ".join(f"{n}: {m}" for n, m in given.items())
        raise ConfigError(
            f"{state.macro}: the patches have different materials ({names}); a score4 rough face "
            "is in its target's one material"
        )
    if not given:
        state.default("targets.0.material", f"{DEFAULT_MATERIAL} (no setMaterial)")
        return DEFAULT_MATERIAL
    return next(iter(given.values()))


def _build(state: State, out_dir: Path, stem: str) -> dict:
    config: dict[str, Any] = {}
    helpers = _surfaces(state)
    config["surfaces"] = {}
    for h in helpers:
        label = (
            f"/Surface/RoughnessHelper/{h.name}"
            if h is not state.describer
            else "/geometry/surface"
        )
        config["surfaces"][h.name] = _spike_surface(
            state, h, label, DESCRIBER_DEFAULTS if h is state.describer else None
        )
    for h in helpers:
        if h is not state.describer and h.name not in state.step_limited:
            half = min(h.values[k][0].value for k in ("dx", "dy"))
            state.report.notes.append(
                "deviation: the original limits steps of ions, alpha, He3, d and t in "
                f"RoughnessHelper {h.name!r} to "
                f"{number_text(DEFAULT_STEP_FRACTION * half * 1e6)} nm "
                "(G4UserLimits of 1 % of the smaller spike half-width, its default without "
                "setStepLimit); score4 sets no per-volume step limit: alphas follow its "
                "light-ion step function (final range 0.1 um) and heavy ions TRIM trajectories "
                "(docs/physics.md)"
            )
    rough, size_x, size_y = _face(state, helpers, config)
    material = _material(state, helpers if state.portals else helpers[:1])
    thickness = parse_quantity(DEFAULT_TARGET_THICKNESS, "length")
    config["targets"] = [
        {
            "name": DEFAULT_TARGET,
            "material": material,
            "size": [size_x, size_y, DEFAULT_TARGET_THICKNESS],
            "position": ["0 mm", "0 mm", f"{number_text(-thickness / 2)} mm"],
            "rough": [rough],
        }
    ]
    state.default(
        "targets.0",
        f"a {material} block named {DEFAULT_TARGET!r}, "
        f"{DEFAULT_TARGET_THICKNESS} thick, under the rough face, with the face at z = 0 "
        "(the original builds the volume under the surface in C++)",
    )
    _source(state, config, DEFAULT_TARGET, material, out_dir, stem)
    _run(state, config)
    order = ("physics", "world", "surfaces", "targets", "source", "run")
    return {k: config[k] for k in order if k in config}


def import_macro(
    path: str | os.PathLike, out: str | os.PathLike | None = None
) -> tuple[dict, ImportReport]:
    """Convert an original SCoRe4 macro into a score4 run configuration.

    Parameters
    ----------
    path
        The macro (``.mac``). ``/control/execute`` macros are read in place.
    out
        Where the configuration will be written; relative file paths in it (the depth table)
        are made relative to its folder. Default: beside the macro.

    Returns
    -------
    config, report
        ``config`` validates with :func:`score4.inputs.config.parse_config` (checked here, with
        ``base_dir`` = the output folder); ``report`` accounts for every command.

    Raises
    ------
    ConfigError
        Missing or unreadable file, a value that cannot be read ("<file> line 12: <command>:
        'abc' is not a length ..."), sizes the original itself refuses, or a macro without any
        rough surface.
    """
    path = Path(path)
    if not path.is_file():
        raise ConfigError(
            f"FILE.mac: {str(path)!r} does not exist"
            if not path.exists()
            else f"FILE.mac: {str(path)!r} is not a file"
        )
    out_path = Path(out) if out is not None else path.with_suffix(".yaml")
    out_dir = out_path.parent
    commands = read_macro(path)
    report = ImportReport(macro=path)
    state = State(path, report)
    collect(state, commands)
    config = _build(state, out_dir, out_path.name.removesuffix(".yaml").removesuffix(".yml"))
    parse_config(config, origin=f"{out_path} (converted from {path})", base_dir=out_dir)
    return config, report
