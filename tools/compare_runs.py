"""Compare two score4 results files event by event: ``python tools/compare_runs.py A.h5 B.h5``.

Every dataset under ``/events`` and ``/primaries`` must be equal exactly (same names, dtypes,
shapes, values; NaN equal to NaN) with the same attributes, and the run records (``/run``
attributes) equal except the entries that differ between two runs of one configuration by
nature: times, host, versions, paths, the backend and worker count, the chunking, Geant4's
warning counts. The root attributes must be equal too. Prints one line; exit status 0 when the
files agree, 1 when they differ, 2 when a file cannot be read.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Iterator
from pathlib import Path

import h5py
import numpy as np

#: Run-record entries that legitimately differ between two runs of the same configuration.
IGNORED_RECORD = frozenset(
    {
        "wall_time_s",
        "created_utc",
        "host",
        "score4_version",
        "geant4_version",
        "geant4_pybind_version",
        "backend",
        "jobs",
        "n_chunks",
        "chunk_events",
        "resumed_chunks",
        "gdml_files",  # absolute paths
        "geant4_warnings",  # each worker process logs its start-up warnings once
    }
)


def _datasets(group: h5py.Group, prefix: str) -> Iterator[tuple[str, h5py.Dataset]]:
    for name, item in group.items():
        path = f"{prefix}/{name}"
        if isinstance(item, h5py.Dataset):
            yield path, item
        else:
            yield from _datasets(item, path)


def _same_value(a: object, b: object) -> bool:
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        a, b = np.asarray(a), np.asarray(b)
        if a.shape != b.shape or a.dtype != b.dtype:
            return False
        if a.dtype.kind in "fc":
            return bool(np.array_equal(a, b, equal_nan=True))
        return bool(np.array_equal(a, b))
    return bool(a == b)


def _attrs(obj: h5py.HLObject, skip: frozenset[str] = frozenset()) -> dict[str, object]:
    return {k: v for k, v in obj.attrs.items() if k not in skip}


def differences(a: Path, b: Path, limit: int = 5) -> list[str]:
    """What differs between results files ``a`` and ``b`` (at most ``limit`` items)."""
    found: list[str] = []
    with h5py.File(a, "r") as fa, h5py.File(b, "r") as fb:
        for where, ga, gb, skip in (
            ("/", fa, fb, frozenset()),
            ("/run", fa.get("run"), fb.get("run"), IGNORED_RECORD),
        ):
            if ga is None or gb is None:
                found.append(f"{where}: missing in {'A' if ga is None else 'B'}")
                continue
            xa, xb = _attrs(ga, skip), _attrs(gb, skip)
            for key in sorted(set(xa) | set(xb)):
                if key not in xa or key not in xb:
                    found.append(
                        f"{where} attribute {key}: only in {'B' if key not in xa else 'A'}"
                    )
                elif not _same_value(xa[key], xb[key]):
                    found.append(f"{where} attribute {key}: {xa[key]!r:.80} != {xb[key]!r:.80}")
        for group in ("events", "primaries"):
            if group not in fa or group not in fb:
                found.append(f"/{group}: missing in {'A' if group not in fa else 'B'}")
                continue
            da, db = (
                dict(_datasets(fa[group], f"/{group}")),
                dict(_datasets(fb[group], f"/{group}")),
            )
            found += [f"{p}: only in {'A' if p in da else 'B'}" for p in sorted(set(da) ^ set(db))]
            for path in sorted(set(da) & set(db)):
                va, vb = da[path][()], db[path][()]
                va, vb = np.asarray(va), np.asarray(vb)
                if va.shape != vb.shape or va.dtype != vb.dtype:
                    found.append(f"{path}: {va.dtype}{va.shape} != {vb.dtype}{vb.shape}")
                elif not _same_value(va, vb):
                    found.append(f"{path}: {_rows_differing(va, vb)} row(s) differ")
                elif not _same_attrs(da[path], db[path]):
                    found.append(f"{path}: attributes differ")
            if not _same_attrs(fa[group], fb[group]):
                found.append(f"/{group}: attributes differ")
            if len(found) >= limit:
                break
    return found[:limit]


def _rows_differing(a: np.ndarray, b: np.ndarray) -> int:
    """Rows (first axis) of two arrays of one shape that are not equal (NaN equal to NaN)."""
    if a.ndim == 0:
        return 1
    same = a == b
    if a.dtype.kind in "fc":
        same |= np.isnan(a) & np.isnan(b)
    return int((~same.reshape(len(a), -1).all(axis=1)).sum())


def _same_attrs(ga: h5py.HLObject, gb: h5py.HLObject) -> bool:
    xa, xb = _attrs(ga), _attrs(gb)
    return xa.keys() == xb.keys() and all(_same_value(xa[k], xb[k]) for k in xa)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("a", type=Path, metavar="A.h5")
    parser.add_argument("b", type=Path, metavar="B.h5")
    args = parser.parse_args(argv)
    try:
        found = differences(args.a, args.b)
        with h5py.File(args.a, "r") as f:
            n = len(f["events/event_id"])
    except (OSError, KeyError) as err:
        print(f"compare_runs: cannot read: {err}", file=sys.stderr)
        return 2
    if found:
        print(f"DIFFERENT {args.a} {args.b}: " + "; ".join(found))
        return 1
    print(f"SAME {args.a} {args.b}: {n} events; every /events and /primaries dataset, run record")
    return 0


if __name__ == "__main__":
    sys.exit(main())
