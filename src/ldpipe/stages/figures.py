"""Figures stage: one figure of ``figures:`` in the configuration, drawn from stage files.

An entry names a figure ``kind`` and the stage outputs it draws (LD maps, Poincaré sections,
manifold sets, a periodic-orbit family, a system's equilibria). :func:`figure_input_files`
lists exactly those files, so asking Snakemake for one figure runs only the stages it needs;
its parameters (:func:`figure_parameters`) are the settings that apply to the kind
(:func:`ldpipe.config.figures.figure_settings`, so only they rerun it) and the text of its caption
(:func:`figure_caption`, the parameters actually used, for the report); :func:`run_figure` draws
it and writes a PNG and a PDF.
"""

from __future__ import annotations

from pathlib import Path

from ..engine import SCHEMES, integrands
from ..errors import ConfigError
from ..io.atomic import check_writable
from ..logs import get_logger
from ..config.figures import KIND_SETTINGS
from ..config.parameters import parameters_from_config
from ..systems import system_kind

log = get_logger(__name__)

#: Kinds that also write an animated GIF beside the PNG and PDF.
ANIMATED = ("ld_animation",)
FORMATS = ("png", "pdf")


def figure_input_files(config: dict, name: str, results: str = "results") -> dict[str, list[str]]:
    """The stage files figure ``name`` draws, by role; exactly these and nothing else.

    Returns
    -------
    dict
        Some of 'equilibria', 'poincare', 'ld_maps', 'manifolds', 'upo', 'nhim_sampling', each a list of paths
        under ``results`` (in the order the figure draws them).
    """
    spec = config["figures"][name]
    kind = spec["kind"]
    files: dict[str, list[str]] = {}
    if kind == "potential":
        files["equilibria"] = [f"{results}/{spec['system']}/equilibria.nc"]
    if kind in ("section_maps", "ld_slices", "ld_ftle", "ld_animation"):
        files["ld_maps"] = [f"{results}/ld/{m}.nc" for m in spec["ld_maps"]]
    if kind == "section_maps":
        if spec.get("poincare"):
            files["poincare"] = [f"{results}/poincare/{p}.nc" for p in spec["poincare"]]
        sets = [s for m in spec["ld_maps"] for s in spec.get("manifold_curves", {}).get(m, [])]
        if sets:
            files["manifolds"] = [f"{results}/manifolds/{s}.nc" for s in dict.fromkeys(sets)]
    if kind == "ld_slices" and spec.get("orbit"):
        files["upo"] = [f"{results}/upo/{spec['orbit']['family']}.nc"]
    if kind == "orbit_family":
        files["upo"] = [f"{results}/upo/{spec['family']}.nc"]
        if spec.get("manifolds"):
            files["manifolds"] = [f"{results}/manifolds/{s}.nc" for s in spec["manifolds"]]
    if kind == "nhim_sample":
        files["nhim_sampling"] = [f"{results}/nhim_sampling/{spec['sampling']}.nc"]
        if spec.get("orbits"):
            files["upo"] = [f"{results}/upo/{family}.nc" for family in spec["orbits"]]
    return files


def figure_outputs(name: str, results: str = "results") -> dict[str, str]:
    return {fmt: f"{results}/figures/{name}.{fmt}" for fmt in FORMATS}


def figure_animation_output(config: dict, name: str, results: str = "results") -> dict[str, str]:
    """The GIF of an animated figure kind (:data:`ANIMATED`), by role ``gif``; none for the others."""
    return {"gif": f"{results}/figures/{name}.gif"} if config["figures"][name]["kind"] in ANIMATED else {}


# ----------------------------------------------------------------------------- captions
# Plain text (Unicode, no reStructuredText markup), so the report renders it as written.

def _number(value) -> str:
    return format(float(value), "g").replace("-", "−")


def _interval(interval) -> str:
    return f"[{_number(interval[0])}, {_number(interval[1])}]"


def _energy_text(energy: dict) -> str:
    (kind, value), = energy.items()
    return f"ΔE = {_number(value)}" if kind == "excess" else f"E = {_number(value)}"


def _energies_text(energies: dict) -> str:
    (kind, values), = energies.items()
    return ("ΔE = " if kind == "excess" else "E = ") + ", ".join(_number(v) for v in values)


def _section_text(section: dict) -> str:
    axes = [axis["name"] for axis in section["axes"]]
    sign = "+" if section.get("sign", 1) == 1 else "−"
    fixed = ", ".join(f"{k} = {v if v == 'saddle' else _number(v)}" for k, v in section.get("fixed", {}).items())
    if "solve" not in section:  # a vector field's: nothing solved
        return f"({', '.join(axes)})" + (f": {fixed}" if fixed else "")
    if "root" in section:  # a solved position
        root = section["root"]
        rule = f"nearest {_number(root['nearest'])}" if isinstance(root, dict) else root
        return f"U_{''.join(axes)}: {fixed}, {section['solve']} the {rule} root"
    return f"U_{''.join(axes)}{sign}: {fixed}, {section['solve']} {'>' if sign == '+' else '<'} 0"


def ld_map_caption(config: dict, map_name: str) -> str:
    """One line on an LD map: section, energy, τ, p, fixed or variable time, saddle region, grid."""
    parameters = parameters_from_config(config, "ld", map_name)
    axes = parameters["section"]["axes"]
    p = integrands.caption(parameters["p"], _number)
    text = (
        f"{map_name}: system {parameters['system_name']}, section {_section_text(parameters['section'])}, "
        + (f"{_energy_text(parameters['energy'])}" if "energy" in parameters
           else f"vector field (no energy), {_start_text(parameters)}")
        + f", τ = {_number(parameters['tau'])}, {p}, {parameters['time']} time"
    )
    if parameters["time"] == "variable":
        region = parameters["region"]
        text += (", saddle region q_s = " + " × ".join(_interval(region[c]) for c in region)
                 + f" in ({', '.join(region)}) (config key ld_maps.{map_name}.region)")
    integrator = parameters["integrator"]
    tolerance = (f"rtol = {_number(integrator['rtol'])}, atol = {_number(integrator['atol'])}"
                 if SCHEMES[integrator["scheme"]].adaptive else f"dt = {_number(integrator['dt'])}")
    text += (f", {axes[0]['points']} × {axes[1]['points']} grid over {axes[0]['name']} ∈ {_interval(axes[0]['range'])}, "
             f"{axes[1]['name']} ∈ {_interval(axes[1]['range'])}, {integrator['scheme']} ({tolerance})")
    return text


def _start_text(parameters: dict) -> str:
    """A map's start time, or its start times (a list or a range)."""
    from ..core.maps.grid import map_start_times  # here: ld_grid brings the engine, which a figure job does not use

    starts = map_start_times(parameters)
    if starts is None:
        return f"start time t0 = {_number(parameters.get('t0', 0.0))}"
    return f"{len(starts)} start times t0 = " + ", ".join(_number(v) for v in starts)


def _poincare_caption(config: dict, name: str) -> str:
    spec = config["poincare_sections"][name]
    axes = spec["initial_conditions"]["axes"]
    surface = spec["section"]
    direction = "increasing" if surface["direction"] == 1 else "decreasing"
    where = _energy_text(spec["energy"]) if "energy" in spec else f"start time t0 = {_number(spec.get('t0', 0.0))}"
    return (f"{name}: system {spec['system']}, {where}, crossings of "
            f"{surface['coordinate']} = {_number(surface['value'])} ({direction}) up to T = {_number(spec['time'])} "
            f"from a {axes[0]['points']} × {axes[1]['points']} grid of initial conditions, "
            f"DOP853 rtol = {_number(spec['integrator']['rtol'])}")


def _manifold_caption(config: dict, name: str) -> str:
    spec = config["manifolds"][name]
    return (f"{name}: orbits of family {spec['orbits']} at {_energy_text(spec['energy'])}, {spec['points']} points "
            f"along the orbit, displacement ε = {_number(spec['displacement'])}, integrated for "
            f"{_number(spec['time'])} time units, cut by {spec['section']['coordinate']} = "
            f"{_number(spec['section']['value'])}")


def _family_caption(config: dict, family: str) -> str:
    spec = config["periodic_orbits"][family]
    near = spec.get("saddle_near")
    where = f"the index-1 saddle nearest ({', '.join(_number(v) for v in near)})" if near else "the lowest index-1 saddle"
    return (f"{family}: Lyapunov family of {where} of {spec['system']}, centre mode {spec['center_mode']}, "
            f"closure tolerance {_number(spec['tolerance'])}")


def _system_caption(config: dict, system: str) -> str:
    spec = config["systems"][system]
    parameters = ", ".join(f"{k} = {_number(v)}" for k, v in spec.get("parameters", {}).items())
    # '**' and '*' would be emphasis markup in the report: write powers and products as ^ and ·.
    what = system_kind(spec).caption(spec).replace("**", "^").replace("*", "·")
    return f"{system}: {what}" + (f" with {parameters}" if parameters else "")


def _formula_flow(spec: dict) -> bool:
    kind = system_kind(spec)
    return kind.formulas and not kind.hamiltonian


def _sampling_caption(config: dict, study: str) -> str:
    spec = config["nhim_sampling"][study]
    grid = ", ".join(f"{c}: {axis['points']} values in {_interval(axis['range'])}" for c, axis in spec["fixed"].items())
    refinement = config["nhim"]["refinement"]
    window = spec["window"]
    return (f"{study}: slices of LD map {ld_map_caption(config, spec['base_map'])}; fixed values on the grid {grid}, "
            f"signs {', '.join(f'{s:+d}' for s in spec['signs'])} of the solved momentum; each slice's point detected "
            f"on a {window['points']} × {window['points']} LD window of half-widths "
            f"{', '.join(_number(w) for w in window['half_width'])} around the prediction from its neighbours "
            f"(widened × {_number(window['widen'])} up to {window['max_widenings']} times; the first slice on the whole "
            f"window, {spec['seed_points']} × {spec['seed_points']}), refined by fates to {_number(refinement['tolerance'])} "
            f"(DOP853 rtol = {_number(refinement['rtol'])}); degenerate slices: curves crossing at less than "
            f"{_number(spec['min_angle'])} rad, a solved momentum smaller in size than {_number(spec['min_momentum'])} × √(2ΔE), "
            f"no crossing found")


def figure_caption(config: dict, name: str) -> dict:
    """Caption material of figure ``name``: the entry's own text and one line per parameter
    group, each as used (the grid cap of a quick run applied)."""
    spec = config["figures"][name]
    kind = spec["kind"]
    lines: list[str] = []
    if kind == "potential":
        lines.append("system " + _system_caption(config, spec["system"]))
        plane = ", ".join(f"{c} ∈ {_interval(r)}" for c, r in spec["plane"].items())
        fixed = ", ".join(f"{c} at the saddle" if v == "saddle" else f"{c} = {_number(v)}"
                          for c, v in spec.get("fixed", {}).items())
        lines.append(f"plane {plane}" + (f", {fixed}" if fixed else "") + f" ({spec['points']} points per axis)")
        lines.append("Hill's regions at " + _energies_text(spec["energies"]))
    if kind == "section_maps":
        lines += ["Poincaré section " + _poincare_caption(config, p) for p in spec.get("poincare", [])]
        lines += ["LD map " + ld_map_caption(config, m) for m in spec["ld_maps"]]
        # the formulas of each flow given by formulas, once per figure (velocity data have none to state)
        flows = sorted({config["ld_maps"][m]["system"] for m in spec["ld_maps"]
                        if _formula_flow(config["systems"][config["ld_maps"][m]["system"]])})
        lines += ["system " + _system_caption(config, system) for system in flows]
        for map_name, sets in spec.get("manifold_curves", {}).items():
            lines += [f"manifold curves on {map_name}: " + _manifold_caption(config, s) for s in sets]
    if kind == "ld_slices":
        lines += ["LD map " + ld_map_caption(config, m) for m in spec["ld_maps"]]
        slices = ", ".join(_number(v) for v in spec["slices"])
        lines.append(f"1D slices at fixed values {slices} of each map's second axis"
                     + (" and through the orbit's point" if spec.get("orbit") and spec["slice_through_orbit"] else ""))
        if spec.get("orbit"):
            energy = spec["orbit"].get("energy")
            where = f"at {_energy_text(energy)}" if energy else "at each map's energy"
            lines.append(f"periodic orbit {where} of family " + _family_caption(config, spec["orbit"]["family"]))
    if kind == "orbit_family":
        lines.append("family " + _family_caption(config, spec["family"]))
        lines.append("orbits at " + (_energies_text(spec["energies"]) if spec.get("energies") else "every target energy"))
        lines += ["manifolds " + _manifold_caption(config, s) for s in spec.get("manifolds", [])]
    if kind == "ld_ftle":
        lines += ["LD map " + ld_map_caption(config, m) for m in spec["ld_maps"]]
        lines.append(f"LD shown: {spec['descriptor']}; FTLE forward and backward over each map's τ, colour scales "
                     f"from the {_number(spec['color_percentiles'][0])}th to the "
                     f"{_number(spec['color_percentiles'][1])}th percentile; grey where not defined")
    if kind == "ld_animation":
        lines += ["LD map " + ld_map_caption(config, m) for m in spec["ld_maps"]]
        lines.append(f"LD shown: {spec['descriptor']}; one frame per start time, {_number(spec['fps'])} a second; "
                     f"one colour scale for every frame, from the {_number(spec['color_percentiles'][0])}th to the "
                     f"{_number(spec['color_percentiles'][1])}th percentile")
    if kind == "nhim_sample":
        lines.append("NHIM sampling " + _sampling_caption(config, spec["sampling"]))
        lines += ["Lyapunov orbit at the study's energy of family " + _family_caption(config, f) for f in spec["orbits"]]
        lines.append("3D projections " + "; ".join("(" + ", ".join(p) + ")" for p in spec["projections"]))
    if kind in ("section_maps", "ld_slices"):
        limits = spec.get("color_limits")
        lines.append(f"LD shown: {spec['descriptor']} (forward + backward for 'total'); colour scale "
                     + (_interval(limits) if limits else
                        f"from the {_number(spec['color_percentiles'][0])}th to the "
                        f"{_number(spec['color_percentiles'][1])}th percentile of the allowed points")
                     + "; energetically forbidden points (never integrated) in grey")
    return {"text": spec.get("caption", "").strip(), "lines": lines}


# ----------------------------------------------------------------------------- drawing

def figure_parameters(config: dict, name: str) -> dict:
    """The parameters of figure ``name`` as its rule passes them (:func:`parameters_from_config`'s,
    which are what the drawing reads, with the caption the report prints)."""
    return {**parameters_from_config(config, "figures", name), "caption": figure_caption(config, name)}


def _as_list(value) -> list[str]:
    if value is None:
        return []
    return [str(value)] if isinstance(value, (str, Path)) else [str(v) for v in value]


def draw_figure(kind: str, settings: dict, inputs: dict):
    """The matplotlib Figure of one figure entry, from its input files by role."""
    inputs = {role: _as_list(paths) for role, paths in inputs.items()}
    if kind == "potential":
        from ..figures.potential import draw_potential

        return draw_potential(settings, equilibria=inputs["equilibria"][0])
    if kind == "section_maps":
        from ..figures.section_maps import draw_section_maps

        by_name = {Path(path).name[: -len(".nc")]: path for path in inputs.get("manifolds", [])}
        curves = {m: [by_name[s] for s in sets] for m, sets in settings.get("manifold_curves", {}).items()}
        return draw_section_maps(settings, poincare=inputs.get("poincare", []), ld_maps=inputs["ld_maps"],
                                 manifolds=curves)
    if kind == "ld_slices":
        from ..figures.ld_slices import draw_ld_slices

        upo = inputs.get("upo", [None])[0] if settings.get("orbit") else None
        return draw_ld_slices(settings, ld_maps=inputs["ld_maps"], upo=upo)
    if kind == "orbit_family":
        from ..figures.orbits import draw_orbit_family

        return draw_orbit_family(settings, upo=inputs["upo"][0], manifolds=inputs.get("manifolds", []))
    if kind == "nhim_sample":
        from ..figures.nhim_sample import draw_nhim_sample

        return draw_nhim_sample(settings, sampling=inputs["nhim_sampling"][0], upo=inputs.get("upo", []))
    if kind == "ld_ftle":
        from ..figures.ld_ftle import draw_ld_ftle

        return draw_ld_ftle(settings, ld_maps=inputs["ld_maps"])
    if kind == "ld_animation":
        from ..figures.ld_animation import draw_ld_animation

        return draw_ld_animation(settings, ld_maps=inputs["ld_maps"])
    raise ConfigError(f"figure kind {kind!r}: expected one of {sorted(KIND_SETTINGS)}")


def refuse_empty_maps(figure_name: str, ld_maps) -> None:
    """Stop, naming map and figure, where an LD map the figure draws has no energetically allowed
    point: its panel would be all grey."""
    from ..io.datafile import open_stage_file

    for path in _as_list(ld_maps):
        dataset = open_stage_file(path, stage="ld_grid", variables=("allowed",), only=True)
        if not dataset.allowed.values.any():
            raise ConfigError(
                f"figure {figure_name!r}: LD map {dataset.attrs.get('map', Path(path).stem)!r} ({path}) has no "
                f"energetically allowed point at E = {float(dataset.attrs['energy']):.12g}, so its panel would be "
                f"empty; choose an energy above the potential somewhere on its section (config key "
                f"ld_maps.{dataset.attrs.get('map', Path(path).stem)}.energy)"
            )


def run_figure(*, figure_name: str, kind: str, settings: dict, caption: dict | None = None, inputs: dict,
               png: str | Path, pdf: str | Path | None = None, gif: str | Path | None = None) -> list[Path]:
    """Draw figure ``figure_name`` from its input files and write it as PNG (and PDF).

    Parameters
    ----------
    figure_name, kind, settings, caption
        As :func:`figure_parameters` gives them (the caption is for the report only).
    inputs : dict
        Input files by role ('equilibria', 'poincare', 'ld_maps', 'manifolds', 'upo', 'nhim_sampling'), as
        :func:`figure_input_files` lists them; other roles are ignored.
    png, pdf : path
        Output files.
    gif : path, optional
        The animation of an animated kind (:data:`ANIMATED`).
    """
    check_writable(png, pdf, gif)  # before any work: never lose a run to a bad path
    from ..figures import style

    log.info("figure %s (%s) from %s", figure_name, kind, {k: _as_list(v) for k, v in inputs.items()})
    refuse_empty_maps(figure_name, inputs.get("ld_maps"))
    with style.figure_style():
        figure = draw_figure(kind, settings, inputs)
        written = style.save_figure(figure, png, pdf)
        if gif is not None and kind in ANIMATED:
            from ..figures.ld_animation import write_ld_animation

            frames = write_ld_animation(settings, _as_list(inputs["ld_maps"])[0], gif)
            log.info("%s: %d frames", gif, frames)
            written.append(Path(gif))
    for path in written:
        log.info("wrote %s (%d kB)", path, path.stat().st_size // 1024)
    return written


def figure_memory_mb(config: dict, name: str) -> int:
    """Memory a figure job needs: one whole LD file at a time (about 80 bytes a grid point) and
    the drawn field of every map (about 10 bytes a point), plus the interpreter and matplotlib."""
    spec = config["figures"][name]
    points = []
    for map_name in spec.get("ld_maps", []):
        axes = parameters_from_config(config, "ld", map_name)["section"]["axes"]
        points.append(axes[0]["points"] * axes[1]["points"])
    return 1000 + (100 * max(points, default=0) + 10 * sum(points)) // 2**20
