"""ldpipe in a notebook: one function per stage, whose keyword arguments are the configuration's keys.

A ``config.yaml`` entry and a call say the same thing::

    ld_maps:
      hh:
        system: henon_heiles
        section: {axes: [...], fixed: {px: 0.0}, solve: x, root: largest}
        energy: {total: 0.125}
        tau: 2.0

    hh = ldpipe.system(name="henon_heiles", formula="(x**2 + y**2)/2 + x**2*y - y**3/3", coordinates=["x", "y"])
    m = ldpipe.ld_map(hh, name="hh", section=ldpipe.section(...), energy=0.125, tau=2.0)

Where an entry names another entry (a map's ``system``, a manifold set's ``orbits``) the call
takes that object or Dataset instead. Each call builds the configuration the entry would sit in,
validates it with the configuration's own schema and rules (so a bad argument gets the message a
bad key gets, naming the argument), and calls in memory the library function that makes the
stage's product (:mod:`ldpipe.core`), the one the stage calls for Snakemake and the command line:
the Dataset returned equals, data and attributes, the file the pipeline writes for the same entry
(but for ``history``, which says when and how a file was written).
"""

from .chaos import chaos_indicators
from .files import open_dataset, plot
from .fluxes import normal_form, saddle_flux, transport
from .invariant_sets import nhim, nhim_sampling, orbit_validation
from .maps import ld_map
from .measurements import accuracy_cost
from .orbits import manifolds, map_manifolds, periodic_orbits, poincare
from .structures import fsle, lavd, structures
from .systems import equilibria, section, system

__all__ = [
    "accuracy_cost", "chaos_indicators", "equilibria", "fsle", "lavd", "ld_map", "manifolds", "map_manifolds",
    "nhim", "nhim_sampling", "normal_form", "open_dataset", "orbit_validation", "periodic_orbits", "plot",
    "poincare", "saddle_flux", "section", "structures", "system", "transport",
]
