"""Pictures of a surface: a height-map image with a scale bar beside a 3D view of the top.

Drawn with matplotlib's object API on an Agg canvas (no display, no global pyplot state), so
it works on headless machines and inside other programs that use pyplot themselves.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure
from matplotlib.ticker import MaxNLocator
from mpl_toolkits.axes_grid1.anchored_artists import AnchoredSizeBar

from score4.common.units import um

from ..files import atomic_output
from .metrology import areal_parameters, mesh_parameters
from .rough import SPIKE_MAP_SAMPLES, Surface

#: Largest number of samples per axis drawn in the 3D view (more makes rendering slow, no clearer).
MAX_3D_SAMPLES = 200
#: Largest number of spike cells per axis drawn in the 3D view (a central window of the grid).
MAX_3D_CELLS = 12
#: Largest number of samples per axis drawn in the image (beyond the pixels of any figure).
MAX_IMAGE_SAMPLES = 2048
#: Smallest number of spike cells per axis drawn in the 3D view.
MIN_3D_CELLS = 4
#: Height of the 3D box relative to its longer lateral side when the surface is nearly flat
#: (below it the heights are stretched, and the title says by how much).
_MIN_Z_ASPECT = 0.25
_CMAP = "viridis"


def nice_length(target: float) -> float:
    """The largest 1, 2 or 5 times a power of ten that is at most ``target`` (> 0)."""
    if not (target > 0 and math.isfinite(target)):
        raise ValueError(f"nice_length: target must be a positive finite number, got {target!r}")
    power = 10.0 ** math.floor(math.log10(target))
    for step in (5.0, 2.0, 1.0):
        if step * power <= target * (1 + 1e-12):
            return step * power
    return power  # unreachable: 1 * power <= target


def _stride(n: int, cap: int) -> int:
    return max(1, math.ceil(n / cap))


def _view_3d(surface: Surface, cap: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, str]:
    """x, y (1-D, mm), z (2-D, mm) for the 3D view, and a note on what part is shown.

    Height maps keep every k-th sample so that each axis has at most ``cap`` + 1. For a spike
    grid, decimation would alias the spikes into noise and thousands of spikes are a blur in
    3D anyway: the view shows a central window of at most :data:`MAX_3D_CELLS` cells per axis
    at the map's full resolution (decimated by a power of two only if that still exceeds
    ``cap``; the map has :data:`~score4.surface.rough.SPIKE_MAP_SAMPLES` samples per cell).
    The window is as small as needed (down to :data:`MIN_3D_CELLS` cells) for the spikes to
    be drawn at their true aspect ratio.
    """
    hm = surface.map
    ny, nx = hm.shape
    if surface.spikes is None:
        sy, sx = _stride(ny - 1, cap), _stride(nx - 1, cap)
        step = max(sx, sy)
        return (
            hm.x[::sx],
            hm.y[::sy],
            hm.heights[::sy, ::sx],
            f"1 sample in {step} per axis" if step > 1 else "",
        )
    per_cell = SPIKE_MAP_SAMPLES
    step = 1
    while step < per_cell // 2 and MAX_3D_CELLS * per_cell / step > cap:
        step *= 2
    grid = surface.spikes
    relief = float(np.nanmax(hm.heights) - np.nanmin(hm.heights))
    cell = max(grid.width_x, grid.width_y)
    true_aspect = math.floor(relief / (_MIN_Z_ASPECT * cell) + 1e-9) if cell > 0 else MAX_3D_CELLS
    most = min(MAX_3D_CELLS, max(MIN_3D_CELLS, true_aspect))
    window = []
    for n, spikes in ((nx, grid.nx), (ny, grid.ny)):
        cells = min(spikes, most)
        first = (spikes - cells) // 2 * per_cell
        window.append(slice(first, min(n, first + cells * per_cell + 1), step))
    wx, wy = window
    x, y, z = hm.x[wx], hm.y[wy], hm.heights[wy, wx]
    note = []
    if grid.nx > most or grid.ny > most:
        note.append(f"central {np.ptp(x) / um:.4g} x {np.ptp(y) / um:.4g} um")
    if step > 1:
        note.append(f"1 sample in {step} per axis")
    return x, y, z, ", ".join(note)


def headline_sq(surface: Surface) -> tuple[float, str]:
    """Sq (mm) for titles and summaries, and how it was obtained.

    Spike grids: exact on the mesh; height maps: ISO 25178 on the map's sample points (the value
    ``score4 surface stats`` prints).
    """
    if surface.spikes is not None:
        return mesh_parameters(surface.top_mesh)["Sq"], "mesh"
    return areal_parameters(surface.map)["Sq"], "map"


def _describe(surface: Surface) -> str:
    spec = surface.spec
    if spec.kind == "spikes":
        return f"spikes: {spec.nx} x {spec.ny} {spec.shape}s"
    if spec.kind == "random":
        return f"random: {spec.model}"
    return f"measured: {Path(spec.file).name}"


def plot_surface(surface: Surface, path: str | Path, dpi: int = 150) -> Path:
    """Write a PNG with the height-map image (left) and a 3D view of the top (right).

    The image shows :attr:`Surface.map` with its physical extent in µm, a colour bar of the
    height in µm and a scale bar; the 3D view is decimated to at most
    :data:`MAX_3D_SAMPLES` samples per axis. The file is written atomically.

    Parameters
    ----------
    surface
        The surface to draw.
    path
        Output file; always PNG, whatever its suffix.
    dpi
        Resolution of the PNG (the figure is 11 x 4.6 inches).

    Returns
    -------
    pathlib.Path
        ``path``.
    """
    path = Path(path)
    hm = surface.map
    sq, how = headline_sq(surface)
    # "compressed": constrained layout that also accounts for the image's fixed aspect; plain
    # "constrained" pushed the image's x label below the figure's edge (measured surface)
    fig = Figure(figsize=(11, 4.6), layout="compressed")
    fig.suptitle(
        f"{_describe(surface)}, {surface.size_x / um:.4g} x {surface.size_y / um:.4g} um, "
        f"Sq = {sq / um:.4g} um ({how})"
    )

    # Height-map image: samples are cell centres, so the extent reaches half a pitch beyond them.
    ax = fig.add_subplot(1, 2, 1)
    sy, sx = _stride(hm.shape[0], MAX_IMAGE_SAMPLES), _stride(hm.shape[1], MAX_IMAGE_SAMPLES)
    z_um = hm.heights[::sy, ::sx] / um
    px, py = hm.pitch_x * sx / um, hm.pitch_y * sy / um
    x0, y0 = hm.x[0] / um, hm.y[0] / um
    extent = (
        x0 - px / 2,
        x0 + px * (z_um.shape[1] - 0.5),
        y0 - py / 2,
        y0 + py * (z_um.shape[0] - 0.5),
    )
    image = ax.imshow(z_um, origin="lower", extent=extent, cmap=_CMAP, interpolation="antialiased")
    ax.set_xlabel("x (um)")
    ax.set_ylabel("y (um)")
    ax.set_title("height map")
    fig.colorbar(image, ax=ax, label="height (um)", shrink=0.9)
    width = extent[1] - extent[0]
    bar = nice_length(width / 4)
    scale_bar = AnchoredSizeBar(
        ax.transData,
        bar,
        f"{bar:g} um",
        "lower right",
        pad=0.4,
        color="white",
        frameon=True,
        size_vertical=(extent[3] - extent[2]) / 100,
    )
    ax.add_artist(scale_bar)
    scale_bar.patch.set(facecolor="black", alpha=0.5, edgecolor="none")

    # 3D view of the (decimated) top; a nearly flat surface gets its heights stretched so that
    # the relief shows, and the title says by how much.
    ax3 = fig.add_subplot(1, 2, 2, projection="3d")
    x, y, z, shown = _view_3d(surface, MAX_3D_SAMPLES)
    xx, yy = np.meshgrid(x / um, y / um)
    ax3.plot_surface(
        xx, yy, z / um, cmap=_CMAP, linewidth=0, antialiased=False, rcount=len(y), ccount=len(x)
    )
    lateral = max(np.ptp(xx), np.ptp(yy))
    relief = float(np.nanmax(z) - np.nanmin(z)) / um
    z_box = min(max(relief / lateral, _MIN_Z_ASPECT), 1.0)
    # zoom < 1 leaves room inside the axes for the tick and axis labels (the z label was cut off)
    ax3.set_box_aspect((np.ptp(xx) / lateral, np.ptp(yy) / lateral, z_box), zoom=0.82)
    scale = z_box * lateral / relief if relief > 0 else 1.0
    notes = ([shown] if shown else []) + (
        [f"heights x{scale:.3g}"] if abs(scale - 1) > 0.05 else ["true aspect"]
    )
    ax3.set_title("3D view" + (f" ({'; '.join(notes)})" if notes else ""))
    ax3.set_xlabel("x (um)")
    ax3.set_ylabel("y (um)")
    ax3.set_zlabel("height (um)")
    ax3.zaxis.set_major_locator(MaxNLocator(3))  # the short z axis crowds its labels otherwise
    ax3.xaxis.set_major_locator(MaxNLocator(5))
    ax3.yaxis.set_major_locator(MaxNLocator(5))

    with atomic_output(path) as tmp:
        fig.savefig(tmp, format="png", dpi=dpi)
    return path
