"""Write synthetic_40x30.plu: a SYNTHETIC Sensofar .plu file (not an instrument measurement).

No .plu file with a redistributable licence exists in any package we can reach (SurfaceTopography
keeps its real samples out of its sdist and wheel; surfalize ships none). So this script packs a
known height map into the binary layout that SurfaceTopography 1.27.1's ``PLUReader`` reads,
which its authors check against a real PLu neox file (their test_plu.py). It needs numpy only:

    python tests/data/topography/make_synthetic_plu.py

and, with ``--reference`` in a scratch venv holding SurfaceTopography (not a score4 dependency:
``python3.11 -m venv /tmp/stv && /tmp/stv/bin/pip install SurfaceTopography==1.27.1``), prints
what SurfaceTopography reads from the file; tests/test_readers_thirdparty.py holds those figures.

Layout, little-endian (field names as in SurfaceTopography's reader):
  header       128 s date, I time, 256 s comment
  calibration  I ny, I nx, I N_tall, f dy_multip, f um/pixel x, f um/pixel y, f x0, f y0,
               f um/pixel tall, f z0
  config 1     I type (3 = topography), I algorithm, I method, I objective, I area type
  scan         I xres_area, I yres_area, I xres, I yres, I na, d incr_z, f range, I n_planes,
               I tpc_umbral_F
  config 2     B restore, B num_layers, B version, B hardware, B num_images, 3 B reserved,
               I factor_delmacio
  per layer    I ny, I nx, ny * nx f4 heights in um (row = y), f min, f max,
               then num_images RGB images of nx * ny * 3 bytes
  1000001 marks a point that was not measured.
"""

from __future__ import annotations

import argparse
import struct
from pathlib import Path

import numpy as np

NY, NX = 30, 40
PITCH_X, PITCH_Y = 0.83, 1.25  # um per pixel, deliberately different
MISSING = (7, 11)  # (row, column) of the one unmeasured point
NOT_MEASURED = 1000001.0
OUT = Path(__file__).with_name("synthetic_40x30.plu")


def heights_um() -> np.ndarray:
    """The stored float32 heights (um): a tilt along y, a wave along x, seeded noise."""
    rows, cols = np.mgrid[0:NY, 0:NX]
    z = (
        0.05 * rows
        + 0.8 * np.sin(2 * np.pi * cols / 16)
        + np.random.default_rng(4).normal(0, 0.1, (NY, NX))
    )
    z = z.astype("<f4")
    z[MISSING] = NOT_MEASURED
    return z


def plu_bytes(z: np.ndarray) -> bytes:
    ny, nx = z.shape
    valid = z[z != NOT_MEASURED]
    out = struct.pack(
        "<128sI256s", b"Fri Mar 10 16:35:59 2023", 1678466159, b"score4 synthetic test file"
    )
    out += struct.pack("<3I7f", ny, nx, nx, 1.0, PITCH_X, PITCH_Y, 0.0, 0.0, 1.0, 0.0)
    out += struct.pack("<5I", 3, 0, 0, 14, 3)  # topography, confocal, objective 14 (10X), FOV area
    out += struct.pack("<5IdfII", nx, ny, nx, ny, 1, 0.1, 10.0, 100, 0)
    out += struct.pack(
        "<8BI", 0, 1, 0xFB, 6, 1, 0, 0, 0, 1
    )  # 1 layer, version 2012, PLu neox, 1 image
    out += struct.pack("<2I", ny, nx) + z.astype("<f4").tobytes()
    out += struct.pack("<2f", valid.min(), valid.max())
    out += bytes([0x80]) * (3 * nx * ny)  # one grey RGB image after the layer
    return out


def reference(path: Path) -> None:
    """What SurfaceTopography (an independent reader) finds in the file."""
    from SurfaceTopography import read_topography

    t = read_topography(str(path))
    h = t.heights()  # (nx, ny), masked where not measured
    print(
        "SurfaceTopography nb_grid_pts",
        t.nb_grid_pts,
        "physical_sizes",
        t.physical_sizes,
        "unit",
        t.unit,
    )
    print(
        "masked points",
        int(np.ma.count_masked(h)),
        "at",
        np.argwhere(np.ma.getmaskarray(h)).tolist(),
    )
    print(
        f"mean {h.mean():.9g} std {h.std():.9g} [0,0] {h[0, 0]:.9g} [39,29] {h[-1, -1]:.9g} [5,3] "
        f"{h[5, 3]:.9g}"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--reference", action="store_true", help="print SurfaceTopography's reading"
    )
    args = parser.parse_args()
    if args.reference:
        reference(OUT)
        return
    OUT.write_bytes(plu_bytes(heights_um()))
    print(f"wrote {OUT} ({OUT.stat().st_size} bytes)")


if __name__ == "__main__":
    main()
