"""Which variables of a dataset are a curvilinear grid's 2-D coordinates, and how its velocities point.

A ``velocity_data`` entry is on a curvilinear grid when its coordinates are 2-D: named in the
entry (``longitude:`` and ``latitude:`` on the sphere, or ``x:`` and ``y:`` naming 2-D
variables), or, when the entry's ``x`` is not in the file, found from CF's ``coordinates``
attribute of ``u`` (the 2-D variables in it whose units or standard name say longitude and
latitude, or projection x and y on the plane). :func:`curvilinear_coordinates` finds and checks
them (:mod:`.curvilinear` integrates on them).

Velocity ``components``: ``geographic`` (u eastward and v northward; x and y on the plane: CF's
``eastward_*``/``northward_*``) or ``grid`` (u along increasing i, v along increasing j, as ROMS
and NEMO write them on their grids), the grid's rotation ``angle`` (from east to the i
direction, counter-clockwise) from a variable in the file when named, computed from the
coordinates otherwise.
"""

from __future__ import annotations

import numpy as np
import xarray as xr

from ...errors import ConfigError

#: The 2-D coordinates' least nodes along each axis (the metric's fourth-order differences take five).
LEAST_NODES = 5
COMPONENTS = ("geographic", "grid")
ANGLE_UNITS = {"radian": 1.0, "radians": 1.0, "rad": 1.0, "degree": np.pi / 180.0, "degrees": np.pi / 180.0}
LONGITUDE_UNITS = ("degrees_east", "degree_east", "degrees_e", "degree_e")
LATITUDE_UNITS = ("degrees_north", "degree_north", "degrees_n", "degree_n")


def _cf_role(variable: xr.DataArray, sphere: bool) -> str | None:
    """'x' or 'y' if a 2-D variable's units or standard name say it is the grid's x (longitude) or y."""
    units = str(variable.attrs.get("units", "")).strip().lower()
    standard = str(variable.attrs.get("standard_name", "")).strip().lower()
    if sphere:
        if standard == "longitude" or units in LONGITUDE_UNITS:
            return "x"
        if standard == "latitude" or units in LATITUDE_UNITS:
            return "y"
        return None
    return {"projection_x_coordinate": "x", "projection_y_coordinate": "y"}.get(standard)


def _from_cf_attribute(dataset: xr.Dataset, u: str, sphere: bool) -> tuple[str, str] | None:
    variable = dataset[u]  # xarray moves a decoded CF attribute to the encoding
    names = str(variable.attrs.get("coordinates", variable.encoding.get("coordinates", ""))).split()
    found = {}
    for name in names:
        if name in dataset.variables and dataset[name].ndim == 2:
            role = _cf_role(dataset[name], sphere)
            if role and role not in found:
                found[role] = name
    return (found["x"], found["y"]) if len(found) == 2 else None


def curvilinear_coordinates(entry: dict, dataset: xr.Dataset, sphere: bool, key: str) -> tuple[str, str] | None:
    """The names of the 2-D x (longitude) and y (latitude) variables of a curvilinear grid, checked
    (2-D on the same dimensions, numbers, no missing value, at least :data:`LEAST_NODES` a side);
    None for a grid of 1-D axes. ``entry`` has its defaults."""
    named = entry.get("longitude"), entry.get("latitude")
    if any(named):
        if not all(named):
            raise ConfigError(f"config key '{key}': give both longitude and latitude (the 2-D coordinate variables), "
                              f"got only {'longitude' if named[0] else 'latitude'}")
        if not sphere:
            raise ConfigError(f"config key '{key}.longitude': 2-D longitude and latitude are on the sphere: give "
                              "coordinates: sphere (on the plane name the 2-D variables as x: and y:)")
        names, keys = named, ("longitude", "latitude")
    elif entry["x"] in dataset.variables and dataset[entry["x"]].ndim == 2:
        names, keys = (entry["x"], entry["y"]), ("x", "y")
    elif entry["x"] not in dataset.variables and entry["u"] in dataset.variables:
        names, keys = _from_cf_attribute(dataset, entry["u"], sphere), ("u", "u")
        if names is None:
            return None
    else:
        return None
    dims = None
    for name, role in zip(names, keys):
        if name not in dataset.variables:
            raise ConfigError(f"config key '{key}.{role}': variable {name!r} not in the file (it has "
                              f"{sorted(map(str, dataset.variables))})")
        variable = dataset[name]
        if variable.ndim != 2 or variable.dtype.kind not in "iuf":
            raise ConfigError(f"config key '{key}.{role}': coordinate {name!r} must be a 2-D array of numbers (a "
                              f"curvilinear grid's), got {variable.ndim}-D {variable.dtype}")
        if dims is not None and variable.dims != dims:
            raise ConfigError(f"config key '{key}.{role}': coordinates {names[0]!r} and {name!r} are on different "
                              f"dimensions ({dims}, {variable.dims}); a curvilinear grid's x and y share theirs")
        dims = variable.dims
        if min(variable.shape) < LEAST_NODES:
            raise ConfigError(f"config key '{key}.{role}': coordinate {name!r} has shape {variable.shape}; a "
                              f"curvilinear grid needs at least {LEAST_NODES} nodes a side")
        values = np.asarray(variable.values, dtype=float)
        missing = ~np.isfinite(values)
        if missing.any():
            where = tuple(int(k) for k in np.argwhere(missing)[0])
            raise ConfigError(f"config key '{key}.{role}': 2-D coordinate {name!r} has {int(missing.sum())} missing "
                              f"values (the first at index {where} of {variable.dims}); every node of a curvilinear "
                              "grid needs its coordinates, land too")
    return names


def velocity_components(entry: dict, dataset: xr.Dataset, key: str) -> str:
    """The entry's ``components`` (:data:`COMPONENTS`), else ``geographic`` if u's and v's CF
    standard names say eastward and northward; a ConfigError asks for it otherwise."""
    given = entry.get("components")
    if given is not None:
        if given not in COMPONENTS:
            raise ConfigError(f"config key '{key}.components': expected one of {list(COMPONENTS)}, got {given!r}")
        return given
    standard = [str(dataset[entry[role]].attrs.get("standard_name", "")) for role in ("u", "v")]
    if standard[0].startswith("eastward") and standard[1].startswith("northward"):
        return "geographic"
    raise ConfigError(f"config key '{key}.components': the grid is curvilinear, and {entry['u']!r}, {entry['v']!r} do "
                      "not say (by CF standard names eastward_*, northward_*) which way they point; give components: "
                      "geographic (u east, v north; x, y on the plane) or grid (u along the grid's i, v along j, as "
                      "ROMS and NEMO write them)")


def angle_variable(entry: dict, dataset: xr.Dataset, dims: tuple[str, ...], key: str) -> tuple[str, float] | None:
    """The entry's ``angle`` variable and radians per its unit, checked (on the coordinates' dims,
    units radians or degrees); None if not named. Only with grid components."""
    name = entry.get("angle")
    if name is None:
        return None
    if entry.get("components") != "grid":
        raise ConfigError(f"config key '{key}.angle': a rotation angle turns grid components east; give "
                          "components: grid with it (geographic components need none)")
    if name not in dataset.variables:
        raise ConfigError(f"config key '{key}.angle': variable {name!r} not in the file")
    if dataset[name].dims != dims:
        raise ConfigError(f"config key '{key}.angle': variable {name!r} has dimensions {dataset[name].dims}; "
                          f"expected the coordinates' {dims}")
    units = str(dataset[name].attrs.get("units", "")).strip().lower()
    if units not in ANGLE_UNITS:
        raise ConfigError(f"config key '{key}.angle': variable {name!r} has units {units or None!r}; expected "
                          "radians or degrees")
    return name, ANGLE_UNITS[units]
