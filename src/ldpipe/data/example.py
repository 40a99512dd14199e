"""A realistic example of ocean-current data: a meandering jet by a coast, as a CF netCDF file.

``python -m ldpipe.data.example OUTPUT.nc`` writes u, v (m/s, float32) on (time, lat, lon): a
perturbed Bickley jet (Rypina et al. 2007, J. Atmos. Sci. 64, 3595) along 37.5 N in a basin 80 W
to 40 W, 25 N to 50 N, every 0.25 degree and every 6 hours over 40 days, with land (missing
values) west of a wavy coastline near 75 W. The jet's streamfunction, in metres on a local plane
x = R cos(37.5 deg) (lon - lon_c), y = R (lat - 37.5 deg), is

    psi = U L (-tanh(y/L) + sech^2(y/L) sum_n eps_n cos(k_n (x - c_n t))),

u = -d psi/dy, v = d psi/dx. Nothing here is fitted to observations: it looks like a western
boundary current's extension and is known exactly.

With ``--files N`` the example is written as N files along time (``example_000.nc``, ... in the
directory OUTPUT), as a model writes its output, for a ``velocity_data`` entry's glob.

With ``--depth N`` the currents are 3-D, on N depth levels from 0 to 1000 m spaced wider with
depth (as ocean models' are): u, v decay as exp(-depth / 300 m) and w = 0 (each level's flow is
divergence-free, so continuity with w = 0 at the surface gives w = 0 everywhere), over a shelf
whose sea floor (missing values below it) deepens from 50 m at the coast to 1000 m 4 degrees east.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import numpy as np
import xarray as xr

from ..io.atomic import atomic_path

EARTH_RADIUS = 6371000.0
U, L = 1.2, 120e3  # jet speed (m/s) and half-width (m)
WAVES = ((0.075, 1, 0.15), (0.4, 2, 0.10), (0.3, 3, 0.05))  # eps_n, wavenumber index n, phase speed c_n (m/s)
WAVELENGTH = 2.0e6  # the longest meander (m): k_n = 2 pi n / WAVELENGTH
LAT_C, LON_C = 37.5, -60.0


def coast_longitude(lat):
    """The coastline: land west of it."""
    return -76.0 + 2.5 * np.sin(np.pi * (np.asarray(lat) - 25.0) / 12.5)


def jet_velocity(lon, lat, t_seconds):
    """(u, v) in m/s of the jet at lon, lat (degrees) and time (seconds)."""
    x = EARTH_RADIUS * math.cos(math.radians(LAT_C)) * np.radians(lon - LON_C)
    y = EARTH_RADIUS * np.radians(lat - LAT_C)
    s = 1.0 / np.cosh(y / L) ** 2
    th = np.tanh(y / L)
    waves_cos = sum(eps * np.cos(2 * np.pi * n / WAVELENGTH * (x - c * t_seconds)) for eps, n, c in WAVES)
    waves_dx = sum(-eps * 2 * np.pi * n / WAVELENGTH * np.sin(2 * np.pi * n / WAVELENGTH * (x - c * t_seconds))
                   for eps, n, c in WAVES)
    return U * (s + 2 * s * th * waves_cos), U * L * s * waves_dx


DECAY_DEPTH, SHELF_WIDTH = 300.0, 4.0  # e-folding depth of the currents (m); shelf width (degrees)


def depth_levels(count: int) -> np.ndarray:
    """``count`` depth levels (m) from 0 to 1000, spaced wider with depth."""
    return 1000.0 * np.linspace(0.0, 1.0, count) ** 1.5


def sea_floor(lon, lat):
    """The sea floor's depth (m): 50 m at the coast, 1000 m from SHELF_WIDTH degrees east of it."""
    return 50.0 + 950.0 * np.clip((np.asarray(lon) - coast_longitude(lat)) / SHELF_WIDTH, 0.0, 1.0)


def example_dataset(days: float = 40.0, step_hours: float = 6.0, resolution: float = 0.25, depths: int = 0) -> xr.Dataset:
    """The example as a Dataset (see the module docstring); ``depths`` levels make it 3-D."""
    lon = np.arange(-80.0, -40.0 + resolution / 2, resolution)
    lat = np.arange(25.0, 50.0 + resolution / 2, resolution)
    time = np.arange(0.0, days + step_hours / 48, step_hours / 24)
    T, LAT, LON = np.meshgrid(time * 86400.0, lat, lon, indexing="ij")
    u, v = jet_velocity(LON, LAT, T)
    land = LON < coast_longitude(LAT)
    dims = ("time", "lat", "lon")
    coords = {"lon": ("lon", lon, {"units": "degrees_east", "standard_name": "longitude"}),
              "lat": ("lat", lat, {"units": "degrees_north", "standard_name": "latitude"}),
              "time": ("time", time, {"units": "days since 2000-01-01", "standard_name": "time",
                                      "calendar": "standard"})}
    if depths:
        depth = depth_levels(depths)
        decay = np.exp(-depth / DECAY_DEPTH)[None, :, None, None]
        u, v = u[:, None] * decay, v[:, None] * decay
        land = land[:, None] | (depth[None, :, None, None] > sea_floor(LON, LAT)[:, None])
        dims = ("time", "depth", "lat", "lon")
        coords["depth"] = ("depth", depth, {"units": "m", "positive": "down", "standard_name": "depth"})
    u = np.where(land, np.nan, u).astype(np.float32)
    v = np.where(land, np.nan, v).astype(np.float32)
    encoding = {"_FillValue": np.float32(-999.0)}
    variables = {"u": (dims, u, {"units": "m/s", "standard_name": "eastward_sea_water_velocity",
                                 "long_name": "eastward velocity"}),
                 "v": (dims, v, {"units": "m/s", "standard_name": "northward_sea_water_velocity",
                                 "long_name": "northward velocity"})}
    if depths:
        variables["w"] = (dims, np.where(land, np.nan, 0.0).astype(np.float32),
                          {"units": "m/s", "standard_name": "upward_sea_water_velocity", "long_name": "upward velocity"})
    dataset = xr.Dataset(
        variables, coords=coords,
        attrs={"Conventions": "CF-1.8", "title": "ldpipe example: a meandering jet by a coast (analytic)",
               "source": "ldpipe.data.example (analytic perturbed Bickley jet; no observations)"})
    for name in variables:
        dataset[name].encoding.update(encoding)
    return dataset


def write_example(path: str | Path, **options) -> Path:
    """Write :func:`example_dataset` to ``path`` (netCDF), atomically."""
    path = Path(path)
    with atomic_path(path) as temporary:
        example_dataset(**options).to_netcdf(temporary)
    return path


def write_example_series(directory: str | Path, files: int, **options) -> list[Path]:
    """Write :func:`example_dataset` split along time into ``files`` netCDF files of about equal
    length (``example_000.nc``, ...) in ``directory``, each atomically: the many files of a model's
    output, which a ``velocity_data`` entry reads as one (a glob or a list as its ``path``)."""
    dataset = example_dataset(**options)
    count = dataset.sizes["time"]
    if not 1 <= files <= count:
        raise ValueError(f"files: expected 1 to {count} (the example's times), got {files}")
    directory = Path(directory)
    paths = []
    for index, part in enumerate(np.array_split(np.arange(count), files)):
        path = directory / f"example_{index:03d}.nc"
        with atomic_path(path) as temporary:
            dataset.isel(time=slice(int(part[0]), int(part[-1]) + 1)).to_netcdf(temporary)
        paths.append(path)
    return paths


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(prog="python -m ldpipe.data.example", description=__doc__.splitlines()[0])
    parser.add_argument("output", help="the netCDF file to write")
    parser.add_argument("--days", type=float, default=40.0)
    parser.add_argument("--depth", type=int, default=0, metavar="N",
                        help="write 3-D currents (u, v, w) on N depth levels (see the module docstring); default 2-D")
    parser.add_argument("--files", type=int, default=1, metavar="N",
                        help="split the example along time into N files example_000.nc, ... in the directory OUTPUT")
    args = parser.parse_args(argv)
    if args.depth and args.depth < 3:
        parser.error(f"--depth {args.depth}: expected at least 3 levels")
    if args.files > 1:
        Path(args.output).mkdir(parents=True, exist_ok=True)
        for path in write_example_series(args.output, args.files, days=args.days, depths=args.depth):
            print(path)
        return
    print(write_example(args.output, days=args.days, depths=args.depth))


if __name__ == "__main__":
    main()
