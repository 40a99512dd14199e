"""The Hénon–Heiles system and ldds' tutorial slice of it (axes y, p_y; p_x = 0; x solved from the
energy, the root x >= 0), as configuration entries shared by the LD stage's and the API's tests."""

import copy

HENON_HEILES = {"formula": "(x**2 + y**2)/2 + x**2*y - y**3/3", "coordinates": ["x", "y"]}
HH_ENERGY = 0.125
_SLICE = {
    "system": "henon_heiles",
    "section": {
        "axes": [{"name": "y", "range": [-0.45, 0.8], "points": 11}, {"name": "py", "range": [-0.5, 0.5], "points": 9}],
        "fixed": {"px": 0.0},
        "solve": "x",
        "root": "largest",
    },
    "energy": {"total": HH_ENERGY},
    "tau": 2.0,
    "integrator": {"scheme": "dop853", "rtol": 1e-8, "atol": 1e-8},
}


def hh_slice(**entries) -> dict:
    """The slice at E = HH_ENERGY, tau 2, dop853 at rtol 1e-8, with ``entries`` added (e.g. tiles):
    a fresh copy each call, as validating a configuration fills its defaults in place."""
    return {**copy.deepcopy(_SLICE), **entries}
