"""Compare the stage files of two runs, variable by variable and attribute by attribute.

Two runs of the same stages with the same parameters should write equal files: a local run and
a SLURM run of one commit, or a run before and after a refactoring. Values are compared as
stored (no CF decoding), bit for bit; where they differ the largest absolute difference is
reported, so a change can be told from a round-off. What cannot be equal between two runs is
left out: the ``history`` attribute (when and how the file was written) and measured run times
(variables named ``*wall_time`` or ``*_seconds``); more attributes can be left out by name
(``git_commit`` when two commits are compared).

    python -m ldpipe.io.filediff RUN_A/results RUN_B/results [--ignore-attribute git_commit]
        [--exclude 'accuracy/*']

exits 0 when every file of either run has an equal twin in the other, 1 otherwise, and prints
one line per difference.
"""

from __future__ import annotations

import argparse
import fnmatch
import re
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import xarray as xr

from .datafile import ENGINE

VOLATILE_ATTRIBUTES = frozenset({"history"})
MEASURED_TIME = re.compile(r"(wall_time|_seconds)$")


@dataclass(frozen=True)
class Difference:
    """One way two files differ: ``where`` (an attribute, a variable, or the file), and how."""

    where: str
    detail: str
    max_abs: float | None = None  # largest |a - b| of a numeric variable of equal shape

    def __str__(self) -> str:
        size = "" if self.max_abs is None else f" (max |a - b| = {self.max_abs:.3g})"
        return f"{self.where}: {self.detail}{size}"


def _same_value(a, b) -> bool:
    a, b = np.asarray(a), np.asarray(b)
    if a.dtype.kind == "f" and b.dtype.kind == "f":
        return a.shape == b.shape and np.array_equal(a, b, equal_nan=True)  # a NaN _FillValue equals itself
    return a.shape == b.shape and np.array_equal(a, b)


def _max_abs(a: np.ndarray, b: np.ndarray) -> float | None:
    if a.shape != b.shape or a.dtype.kind not in "fiub" or b.dtype.kind not in "fiub":
        return None
    difference = np.abs(a.astype(np.float64) - b.astype(np.float64))
    return float(np.max(difference)) if difference.size else 0.0


def _attribute_differences(a: dict, b: dict, where: str, ignore: frozenset[str]) -> list[Difference]:
    found = []
    for key in sorted((set(a) | set(b)) - ignore):
        if key not in a or key not in b:
            found.append(Difference(f"{where}attribute {key!r}", f"only in {'the first' if key in a else 'the second'}"))
        elif not _same_value(a[key], b[key]):
            found.append(Difference(f"{where}attribute {key!r}", f"{a[key]!r} != {b[key]!r}"[:300]))
    return found


def compare_files(first: str | Path, second: str | Path, *,
                  ignore_attributes: frozenset[str] = VOLATILE_ATTRIBUTES) -> list[Difference]:
    """Every difference between two netCDF files as stored; [] when they are equal."""
    with xr.open_dataset(first, engine=ENGINE, decode_cf=False) as a, xr.open_dataset(
        second, engine=ENGINE, decode_cf=False
    ) as b:
        found = _attribute_differences(dict(a.attrs), dict(b.attrs), "", ignore_attributes)
        for name in sorted(set(a.variables) | set(b.variables)):
            if MEASURED_TIME.search(name):
                continue
            if name not in a.variables or name not in b.variables:
                found.append(Difference(f"variable {name!r}", f"only in {'the first' if name in a.variables else 'the second'}"))
                continue
            va, vb = a[name], b[name]
            if va.dims != vb.dims:
                found.append(Difference(f"variable {name!r}", f"dimensions {va.dims} != {vb.dims}"))
                continue
            values_a, values_b = va.values, vb.values
            if not _same_value(values_a, values_b):
                detail = "values differ" if values_a.shape == values_b.shape else f"shape {values_a.shape} != {values_b.shape}"
                found.append(Difference(f"variable {name!r}", detail, _max_abs(values_a, values_b)))
            found += _attribute_differences(dict(va.attrs), dict(vb.attrs), f"variable {name!r} ", frozenset())
    return found


def compare_runs(first: str | Path, second: str | Path, *, ignore_attributes: frozenset[str] = VOLATILE_ATTRIBUTES,
                 exclude: tuple[str, ...] = ()) -> dict[str, list[Difference]]:
    """The differences of the netCDF files under two folders, by relative path; equal files map to []."""
    first, second = Path(first), Path(second)

    def files(root: Path) -> set[str]:
        paths = {path.relative_to(root).as_posix() for path in root.rglob("*.nc")}
        return {path for path in paths if not any(fnmatch.fnmatch(path, pattern) for pattern in exclude)}

    names_a, names_b = files(first), files(second)
    report = {}
    for name in sorted(names_a | names_b):
        if name not in names_a or name not in names_b:
            report[name] = [Difference("file", f"only under {first if name in names_a else second}")]
        else:
            report[name] = compare_files(first / name, second / name, ignore_attributes=ignore_attributes)
    return report


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m ldpipe.io.filediff", description=__doc__.split("\n\n")[0])
    parser.add_argument("first", type=Path, help="a results folder (or a netCDF file)")
    parser.add_argument("second", type=Path, help="the results folder (or file) to compare it with")
    parser.add_argument("--ignore-attribute", action="append", default=[], metavar="NAME",
                        help="a global attribute to leave out besides 'history' (repeatable), e.g. git_commit")
    parser.add_argument("--exclude", action="append", default=[], metavar="GLOB",
                        help="relative paths to leave out (repeatable), e.g. 'accuracy/*'")
    args = parser.parse_args(argv)
    for path in (args.first, args.second):
        if not path.exists():
            parser.error(f"{path}: no such file or folder")
    ignore = VOLATILE_ATTRIBUTES | frozenset(args.ignore_attribute)
    if args.first.is_file():
        report = {args.first.name: compare_files(args.first, args.second, ignore_attributes=ignore)}
    else:
        report = compare_runs(args.first, args.second, ignore_attributes=ignore, exclude=tuple(args.exclude))
    equal = [name for name, found in report.items() if not found]
    for name, found in report.items():
        for difference in found:
            print(f"{name}: {difference}")
    print(f"{len(equal)} of {len(report)} files equal")
    return 0 if len(equal) == len(report) else 1


if __name__ == "__main__":
    sys.exit(main())
