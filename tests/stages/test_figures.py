"""Figures: the drawing functions on small synthetic stage files, the figure configuration,
captions, and (slow) the plan Snakemake makes for one named figure."""

import json
import re
from pathlib import Path
from types import SimpleNamespace

import jinja2
import matplotlib.pyplot as plt
import numpy as np
import pytest
import xarray as xr
import yaml
from docutils.core import publish_parts
from matplotlib.image import imread

from ldpipe.config import load_config, validate_config
from ldpipe.io.datafile import missing_value_encoding, write_stage_file
from ldpipe.errors import ConfigError
from ldpipe.figures import style
from ldpipe.figures.data import Orbit, _split_curve, load_ld_map, orbit_section_points
from ldpipe.core.sections import Section, section_states
from ldpipe.stages.equilibria import run_equilibria
from ldpipe.stages.figures import draw_figure, figure_caption, figure_input_files, figure_parameters, run_figure
from support.tick_labels import assert_readable_tick_labels
from support.workflow import ROOT, job_counts, run_snakemake

BARBANIS = {"builtin": "barbanis_2dof", "parameters": {"omega_x": 1.0, "omega_y": 1.1, "delta": -0.11}}
E_C = 15.125  # the paper's critical energy of both Barbanis 2 DoF saddles
SADDLE = np.array([5.5, -np.sqrt(50.0)])  # closed form: x = wy^2/(2|delta|)... y^2 = wx^2 x/|delta|


def paraboloid(x, px):
    return 1.0 + x**2 + px**2


def ld_file(path, barbanis, *, excess=0.125, fixed_y=0.0, points=(41, 37), time="fixed", spec_y=None,
            total=paraboloid):
    """A synthetic LD map on U_xpx (y = fixed_y, p_y > 0) written like the LD stage writes one
    (its recorded spec fixes y at ``spec_y`` if given, e.g. 'saddle').

    The allowed mask is the real one (section_states); the total LD is ``total(x, px)`` (default
    1 + x^2 + p_x^2), half forward and half backward, on allowed points and missing (NaN)
    elsewhere, as the stage leaves points it never integrates.
    """
    section = Section(axes=("x", "px"), ranges=((-6.0, 6.0), (-6.0, 6.0)), shape=points, fixed={"y": fixed_y},
                      solve="py")
    energy = E_C + excess
    _, allowed, solved = section_states(barbanis, section, energy)
    x, px = section.axis_values()
    field = np.where(allowed, total(x[:, None], px[None, :]), np.nan)
    dataset = xr.Dataset(
        {"ld_forward": (("x", "px"), field / 2, {}, missing_value_encoding()),
         "ld_backward": (("x", "px"), field / 2, {}, missing_value_encoding()),
         "allowed": (("x", "px"), allowed), "py": (("x", "px"), solved)},
        coords={"x": x, "px": px},
        attrs={"map": Path(path).stem, "system": "barbanis_2dof", "energy": energy, "excess_energy": excess,
               "critical_energy": E_C, "saddle_position": SADDLE, "tau": 50.0, "time_mode": time,
               "region_lower": np.array([4.5, -8.5]), "region_upper": np.array([6.5, -5.5])},
    )
    parameters = {"map_name": Path(path).stem, "system_name": "barbanis_2dof", "system_spec": BARBANIS,
                  "section": {"axes": [{"name": "x", "range": [-6.0, 6.0], "points": points[0]},
                                       {"name": "px", "range": [-6.0, 6.0], "points": points[1]}],
                              "fixed": {"y": fixed_y if spec_y is None else spec_y}, "solve": "py", "sign": 1},
                  "energy": {"excess": excess}, "tau": 50, "p": 0.5, "time": time}
    return write_stage_file(dataset, path, stage="ld_grid", title="synthetic LD map", parameters=parameters)


def poincare_file(path, *, excess=0.125):
    """A synthetic Poincaré file: crossings on the circle x^2 + p_x^2 = 4 (any points will do)."""
    angles = np.linspace(0, 2 * np.pi, 50)
    states = np.zeros((1, 50, 4))
    states[0, :, 0], states[0, :, 2] = 2 * np.cos(angles), 2 * np.sin(angles)
    dataset = xr.Dataset(
        {"crossing_state": (("trajectory", "crossing", "phase"), states),
         "crossing_valid": (("trajectory", "crossing"), np.ones((1, 50), dtype=bool))},
        coords={"phase": ["x", "y", "px", "py"]},
        attrs={"energy": E_C + excess, "excess_energy": excess, "critical_energy": E_C},
    )
    parameters = {"system_name": "barbanis_2dof", "system_spec": BARBANIS, "energy": {"excess": excess},
                  "initial_conditions": {"axes": [{"name": "x", "range": [-6.0, 6.0], "points": 10},
                                                  {"name": "px", "range": [-6.0, 6.0], "points": 10}],
                                         "fixed": {"y": 0.0}, "solve": "py", "sign": 1}}
    return write_stage_file(dataset, path, stage="poincare", title="synthetic Poincaré section", parameters=parameters)


def upo_file(path, barbanis):
    """A synthetic 'orbit': a segment through the saddle along x = y + c, sampled over a period
    (the figure code does not care that it is not a solution)."""
    t = np.linspace(0.0, 1.0, 201)
    trajectory = np.zeros((1, 201, 4))
    trajectory[0, :, 0] = SADDLE[0] + 0.3 * np.sin(2 * np.pi * t)
    trajectory[0, :, 1] = SADDLE[1] + 0.3 * np.sin(2 * np.pi * t)
    trajectory[0, :, 2] = trajectory[0, :, 3] = 0.6 * np.pi * np.cos(2 * np.pi * t)
    dataset = xr.Dataset(
        {"trajectory": (("orbit", "sample", "phase"), trajectory), "energy": ("orbit", [E_C + 0.125]),
         "excess_energy": ("orbit", [0.125]), "period": ("orbit", [1.0])},
        coords={"phase": ["x", "y", "px", "py"]},
        attrs={"saddle_position": SADDLE, "critical_energy": E_C},
    )
    return write_stage_file(dataset, path, stage="upo", title="synthetic family",
                            parameters={"system_name": "barbanis_2dof", "system_spec": BARBANIS})


def rendered(figure) -> np.ndarray:
    """The figure's pixels as drawn (RGB in [0, 1], rows from the top), at its dpi."""
    figure.canvas.draw()
    return np.asarray(figure.canvas.buffer_rgba())[..., :3] / 255.0


def pixels_at(image: np.ndarray, ax, x: float, y: float, radius: int = 0) -> np.ndarray:
    """The pixels of ``image`` within ``radius`` of the data point (x, y) of ``ax``, shape (k, 3)."""
    column, height = ax.transData.transform((x, y))
    row, column = int(image.shape[0] - height), int(column)
    return image[row - radius:row + radius + 1, column - radius:column + radius + 1].reshape(-1, 3)


def map_colors(values: np.ndarray, allowed: np.ndarray, percentiles=(5.0, 99.9)) -> np.ndarray:
    """What a map's cells must look like: viridis over the given percentiles of the allowed values
    (the documented colour scale), FORBIDDEN_COLOR where not allowed; RGB, shape values.shape + (3,)."""
    low, high = np.percentile(values[allowed], percentiles)
    colors = plt.get_cmap("viridis")(np.clip((values - low) / (high - low), 0.0, 1.0))[..., :3]
    colors[~allowed] = plt.matplotlib.colors.to_rgb(style.FORBIDDEN_COLOR)
    return colors


@pytest.fixture(scope="module")
def equilibria_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("equilibria") / "equilibria.nc"
    return run_equilibria(system_name="barbanis_2dof", system_spec=BARBANIS,
                          box={"x": [-20.0, 20.0], "y": [-20.0, 20.0]}, output=path)


def test_ld_map_masks_the_forbidden_region(tmp_path, barbanis):
    path = ld_file(tmp_path / "m.nc", barbanis)
    ld_map = load_ld_map(path)
    # Invariant: on y = 0, V = x^2/2 (omega_x = 1), so the allowed points are the disc x^2 + px^2 <= 2E.
    x, px = np.meshgrid(ld_map.first, ld_map.second, indexing="ij")
    np.testing.assert_array_equal(~ld_map.values.mask, x**2 + px**2 <= 2 * (E_C + 0.125))
    # The total descriptor is forward + backward: 1 + x^2 + px^2 where allowed.
    np.testing.assert_allclose(ld_map.values.compressed(), (1 + x**2 + px**2)[~ld_map.values.mask])


def test_section_maps_figure_has_labels_colour_bar_grey_forbidden_and_green_boundary(tmp_path, barbanis):
    settings = {"kind": "section_maps", "ld_maps": ["m"], "poincare": ["p"], "manifold_curves": {},
                "descriptor": "total", "color_percentiles": [5.0, 99.9], "color_limits": None, "point_size": 0.6}
    inputs = {"ld_maps": [ld_file(tmp_path / "m.nc", barbanis)], "poincare": [poincare_file(tmp_path / "p.nc")]}
    with style.figure_style():
        figure = draw_figure("section_maps", settings, inputs)
    poincare_ax, map_ax = figure.axes[0], figure.axes[1]
    assert (map_ax.get_xlabel(), map_ax.get_ylabel()) == ("$x$", "$p_x$")
    colorbars = [ax for ax in figure.axes if ax.get_ylabel() == r"$\mathcal{L}$"]
    assert len(colorbars) == 1
    image = map_ax.get_images()[0]
    data = image.get_array()  # transposed: (px, x)
    assert np.ma.getmaskarray(data).any() and not np.ma.getmaskarray(data).all()
    assert image.cmap.get_bad()[:3] == pytest.approx(plt.matplotlib.colors.to_rgb(style.FORBIDDEN_COLOR))
    assert image.get_rasterized()
    # The colour scale comes from allowed points only (LD >= 1 there), never the forbidden zeros.
    assert image.norm.vmin >= 1.0
    # Closed form: the green energy boundary of U_xpx is the circle x^2 + px^2 = 2E, to the grid spacing.
    boundary = [c for c in poincare_ax.collections if c.get_edgecolor().size and
                np.allclose(c.get_edgecolor()[0][:3], plt.matplotlib.colors.to_rgb(style.BOUNDARY_COLOR))]
    assert len(boundary) == 1
    vertices = np.concatenate([p.vertices for p in boundary[0].get_paths()])
    radius = np.hypot(vertices[:, 0], vertices[:, 1])
    np.testing.assert_allclose(radius, np.sqrt(2 * (E_C + 0.125)), atol=2 * 12.0 / 600)
    # The pixels drawn: where the circle x^2 + px^2 = 2E crosses the axes, a green pixel within
    # 2 px (the 1 pt line); at four of the synthetic crossings (x, px) = 2 (cos a, sin a), a dark
    # point within 2 px; the map's cells at grid nodes in the colours their values and the colour
    # scale give (measured within 1 level of 255; bound 5), its corners grey. A transposed or empty
    # panel fails (the grid is 41 x 37 and the nodes are off its diagonal).
    image = rendered(figure)
    green = np.array(plt.matplotlib.colors.to_rgb(style.BOUNDARY_COLOR))
    for x, px in np.sqrt(2 * (E_C + 0.125)) * np.array([[1, 0], [-1, 0], [0, 1], [0, -1]]):
        assert np.min(np.abs(pixels_at(image, poincare_ax, x, px, radius=2) - green).max(axis=1)) < 0.02
    angles = np.linspace(0, 2 * np.pi, 50)  # poincare_file's crossings
    for k in (0, 12, 25, 37):
        assert pixels_at(image, poincare_ax, 2 * np.cos(angles[k]), 2 * np.sin(angles[k]), radius=2).min() < 0.6
    assert np.all(pixels_at(image, poincare_ax, 4.0, 0.0, radius=2) == 1.0)  # nothing drawn there
    x, px = np.linspace(-6, 6, 41), np.linspace(-6, 6, 37)
    grid_x, grid_px = np.meshgrid(x, px, indexing="ij")
    allowed = grid_x**2 + grid_px**2 <= 2 * (E_C + 0.125)
    colors = map_colors(paraboloid(grid_x, grid_px), allowed)
    for i, j in ((20, 18), (30, 20), (8, 25), (14, 5), (33, 30), (1, 1), (39, 35)):
        np.testing.assert_allclose(pixels_at(image, map_ax, x[i], px[j])[0], colors[i, j], atol=0.02)
    assert_readable_tick_labels(figure, tmp_path)  # saved, then closed


def test_ld_slices_with_orbit_marks_where_it_pierces_each_section(tmp_path, barbanis):
    maps = [ld_file(tmp_path / f"k{i}.nc", barbanis, fixed_y=k, time="variable")
            for i, k in enumerate((-7.0, -7.1))]
    settings = {"kind": "ld_slices", "ld_maps": ["k0", "k1"], "slices": [0.0], "slice_through_orbit": True,
                "orbit": {"family": "f", "energy": {"excess": 0.125}}, "descriptor": "total",
                "color_percentiles": [5.0, 99.9], "color_limits": None, "view": [20.0, -60.0]}
    with style.figure_style():
        figure = draw_figure("ld_slices", settings, {"ld_maps": maps, "upo": [upo_file(tmp_path / "f.nc", barbanis)]})
    curve_ax, map_ax = figure.axes[0], figure.axes[1]
    # The synthetic orbit has x - y = 5.5 + sqrt(50): at y = -7.0 it is at x = 5.5 + sqrt(50) - 7.0.
    markers = [line for line in map_ax.get_lines() if line.get_marker() == "o"]
    assert len(markers) == 1
    assert markers[0].get_xdata()[0] == pytest.approx(5.5 + np.sqrt(50.0) - 7.0, abs=1e-9)
    # One slice at p_x = 0 and one through the orbit's point, each a curve above and a line on the map.
    assert len(curve_ax.get_legend().get_texts()) == 2
    assert curve_ax.get_ylabel() == r"$\mathcal{L}$" and map_ax.get_ylabel() == "$p_x$"
    assert any(ax.name == "3d" for ax in figure.axes)  # the view of the orbit threading the sections
    assert_readable_tick_labels(figure, tmp_path)  # saved, then closed


def test_ld_slices_resolve_a_saddle_coordinate_from_the_map_file(tmp_path, barbanis):
    # The map's spec fixes y at 'saddle'; the file's saddle is the closed-form (5.5, -sqrt(50)).
    path = ld_file(tmp_path / "s.nc", barbanis, fixed_y=SADDLE[1], time="variable", spec_y="saddle")
    assert load_ld_map(path).section.fixed == {"y": pytest.approx(-np.sqrt(50.0), rel=0, abs=1e-15)}
    settings = {"kind": "ld_slices", "ld_maps": ["s"], "slices": [0.0], "slice_through_orbit": True,
                "orbit": {"family": "f", "energy": {"excess": 0.125}}, "descriptor": "total",
                "color_percentiles": [5.0, 99.9], "color_limits": None, "view": [20.0, -60.0]}
    with style.figure_style():
        figure = draw_figure("ld_slices", settings, {"ld_maps": [path], "upo": [upo_file(tmp_path / "f.nc", barbanis)]})
    # The synthetic orbit has x - y = 5.5 + sqrt(50): on y = -sqrt(50) it is at x = 5.5 (closed form).
    markers = [line for line in figure.axes[1].get_lines() if line.get_marker() == "o"]
    assert len(markers) == 1
    assert markers[0].get_xdata()[0] == pytest.approx(5.5, abs=1e-9)
    plt.close(figure)


def test_orbit_section_points_on_a_circle():
    # Closed form: the circle (cos t, sin t) with p = (-sin t, cos t) meets y = 1/2 with p_y > 0
    # at t = pi/6, i.e. x = sqrt(3)/2, p_x = -1/2 (linear interpolation: error O(h^2)).
    t = np.linspace(0.0, 2 * np.pi, 2001)
    orbit = Orbit(phase=("x", "y", "px", "py"),
                  trajectory=np.stack([np.cos(t), np.sin(t), -np.sin(t), np.cos(t)], axis=1),
                  energy=0.5, excess_energy=0.0, period=2 * np.pi)
    points = orbit_section_points(orbit, "y", 0.5, "py", 1)
    assert points.shape == (1, 4)
    np.testing.assert_allclose(points[0, [0, 2]], [np.sqrt(3) / 2, -0.5], atol=1e-5)
    assert orbit_section_points(orbit, "y", 0.5, "py", -1)[0, 0] == pytest.approx(-np.sqrt(3) / 2, abs=1e-5)


def test_split_curve_keeps_a_closed_curve_whole_and_breaks_at_gaps():
    angles = np.linspace(0, 2 * np.pi, 100, endpoint=False)
    circle = np.stack([np.cos(angles), np.sin(angles)], axis=1)
    pieces = _split_curve(circle, np.ones(100, dtype=bool))
    assert len(pieces) == 1 and np.allclose(pieces[0][0], pieces[0][-1])  # closed
    valid = np.ones(100, dtype=bool)
    valid[[20, 60]] = False
    assert sorted(len(p) for p in _split_curve(circle, valid)) == [39, 59]  # 21..59, then 61..99 + 0..19
    jump = circle.copy()
    jump[50:] += 10.0  # two sheets: no line across the gap
    assert len(_split_curve(jump, np.ones(100, dtype=bool))) == 2


def test_potential_figure_marks_the_paper_saddles(equilibria_file, tmp_path):
    settings = {"kind": "potential", "system": "barbanis_2dof", "plane": {"x": [-10.0, 15.0], "y": [-12.0, 12.0]},
                "fixed": {}, "energies": {"excess": [-1.0, 1.0]}, "points": 60, "levels": 10, "surface": True,
                "potential_range": None}
    with style.figure_style():
        figure = draw_figure("potential", settings, {"equilibria": [equilibria_file]})
    contour_ax = figure.axes[0]
    saddles = [line for line in contour_ax.get_lines() if line.get_marker() == "x"][0]
    # Paper: saddles at (5.5, +-7.0711).
    np.testing.assert_allclose(sorted(zip(saddles.get_xdata(), saddles.get_ydata())),
                               [(5.5, -np.sqrt(50.0)), (5.5, np.sqrt(50.0))], atol=1e-9)
    titles = [ax.get_title(loc="right") for ax in figure.axes]
    assert r"$\Delta E = -1.000$" in titles and r"$\Delta E = 1.000$" in titles
    assert contour_ax.get_xlabel() == "$x$" and contour_ax.get_ylabel() == "$y$"
    # The pixels drawn: red at both saddles of the contour panel; in each Hill's region panel grey
    # (HILL_COLOR) where V <= E and white elsewhere, at points of closed-form V, each at least 0.6
    # from the boundary V = E (8 px): V(0, 0) = 0 and V(12, -11) = -14.5 inside both; V(-8, 0) = 32
    # outside both; on x = 5.5, V = E_c = 15.125 for every y, so (5.5, +-6) is outside at dE = -1 and
    # inside at dE = +1 (the bottlenecks open). A swapped axis or an empty panel fails.
    image = rendered(figure)
    for y in (-np.sqrt(50.0), np.sqrt(50.0)):
        np.testing.assert_allclose(pixels_at(image, contour_ax, 5.5, y)[0], (1.0, 0.0, 0.0), atol=0.02)
    hill = np.array(plt.matplotlib.colors.to_rgb(style.HILL_COLOR))
    panels = {ax.get_title(loc="right"): ax for ax in figure.axes}
    for excess in (-1.0, 1.0):
        ax = panels[rf"$\Delta E = {excess:.3f}$"]
        for x, y, inside in ((0.0, 0.0, True), (12.0, -11.0, True), (-8.0, 0.0, False),
                             (5.5, -6.0, excess > 0), (5.5, 6.0, excess > 0)):
            np.testing.assert_allclose(pixels_at(image, ax, x, y)[0], hill if inside else (1.0, 1.0, 1.0), atol=0.02)
    assert_readable_tick_labels(figure, tmp_path)  # saved, then closed


def normal_form_study(excess: np.ndarray) -> xr.Dataset:
    """A synthetic normal-form study (any numbers will do for its drawing): flux 40 dE^2, the
    harmonic estimate and the Monte Carlo flux a few 1e-3 off, a truncation error 1e-3 dE flux."""
    flux = 40.0 * excess**2
    orders = np.array([2, 4, 6, 8])
    return xr.Dataset(
        {"excess_energy": ("energy", excess), "flux": ("energy", flux),
         "flux_harmonic": ("energy", flux * (1 + 0.004 * excess / excess.max())),
         "flux_truncation_error": ("energy", 1e-3 * flux * excess),
         "flux_by_order": (("energy", "order"), flux[:, None] * (1 + 1e-3 * excess[:, None] ** (orders / 2))),
         "monte_carlo_excess_energy": ("sample", excess), "flux_monte_carlo": ("sample", flux * 1.003),
         "flux_monte_carlo_stderr": ("sample", flux * 0.002)},
        coords={"order": orders}, attrs={"n_dof": 3, "system": "synthetic", "saddle_position": [1.0, 2.0, 3.0]})


@pytest.mark.parametrize("excess", [[0.125, 0.25, 0.5, 1.0, 2.25, 5.0], [0.0023, 0.004, 0.006], [0.01, 0.3, 90.0]],
                         ids=["1.6 decades", "under a decade", "4 decades"])
def test_normal_form_figure_tick_labels_are_readable(tmp_path, excess):
    """The main run's energies (0.125 ... 5: matplotlib labelled the minor ticks 2×10⁻¹ 3×10⁻¹ ...
    into one another), a span under a decade (no decade inside) and a wide one."""
    from ldpipe.figures.normal_form import normal_form_figure

    assert_readable_tick_labels(normal_form_figure(normal_form_study(np.array(excess))), tmp_path)


@pytest.mark.parametrize(("position", "shown"), [
    ([20.17, 1e-310], "(20.17, 0)"),  # subnormal: what an underflow leaves
    ([20.17, -3e-17, 0.0], "(20.17, 0, 0)"),  # 20.17 + 3e-17 == 20.17 in doubles: zero to rounding
    ([-0.0, 1e-3], "(0, 0.001)"),  # no sign on a zero; a small coordinate that is no rounding stays
    ([1e-310, -1e-300], "(0, -1e-300)"),  # a normal number is its own scale, however small
])
def test_the_normal_form_title_shows_a_coordinate_zero_to_rounding_as_0(position, shown):
    from ldpipe.figures.normal_form import normal_form_figure

    assert 20.17 + 3e-17 == 20.17 and 1e-310 < np.finfo(float).tiny  # the cases are what they say
    study = normal_form_study(np.array([0.125, 0.25, 0.5]))
    figure = normal_form_figure(study.assign_attrs(saddle_position=position))
    assert figure.axes[0].get_title() == f"synthetic (3 DoF)\nsaddle at {shown}"
    plt.close(figure)


def test_orbit_family_figure_tick_labels_are_readable(tmp_path, barbanis):
    from ldpipe.config import load_schema

    properties = load_schema()["$defs"]["figure"]["properties"]
    settings = {key: properties[key].get("default") for key in ("energies", "configuration", "view3d_axes",
                                                                 "view3d_limits", "trajectories_per_branch", "view")}
    with style.figure_style():
        figure = draw_figure("orbit_family", {**settings, "kind": "orbit_family", "family": "f"},
                             {"upo": [upo_file(tmp_path / "f.nc", barbanis)]})
    assert_readable_tick_labels(figure, tmp_path)


def tilted(x, px):
    return 10.0 + x + 0.0 * px


def test_run_figure_writes_small_png_and_pdf_with_the_map_rasterized(tmp_path, barbanis):
    path = ld_file(tmp_path / "m.nc", barbanis, points=(300, 300), total=tilted)
    settings = {"kind": "ld_slices", "ld_maps": ["m"], "slices": [0.0, 1.0], "slice_through_orbit": True,
                "descriptor": "forward", "color_percentiles": [5.0, 99.9], "color_limits": None, "view": [20.0, -60.0]}
    written = run_figure(figure_name="m", kind="ld_slices", settings=settings, inputs={"ld_maps": path},
                         png=tmp_path / "out/m.png", pdf=tmp_path / "out/m.pdf")
    assert [p.name for p in written] == ["m.png", "m.pdf"]
    pdf = (tmp_path / "out/m.pdf").read_bytes()
    assert b"/Subtype /Image" in pdf  # the map is an embedded raster, not 90 000 vector cells
    assert len(pdf) < 400_000 and (tmp_path / "out/m.png").stat().st_size < 400_000
    assert not list((tmp_path / "out").glob(".*"))  # no temporary file left behind
    # The PNG's pixels. The map (forward LD (10 + x) / 2 on the disc x^2 + px^2 <= 2E, forbidden
    # corners grey) fills its axes, x and px in [-6, 6]: its edges are the outermost rows and
    # columns of more than 100 grey pixels (all grey there: |x| or |px| > sqrt(2E) = 5.5; text
    # antialiasing gives a few). Inside, at grid nodes off the slice lines, the colour is the
    # value's under the documented scale (measured within 1 level of 255; bound 5): it changes
    # along x and not along px, so transposed axes fail, as does an empty or uniform map.
    image = imread(tmp_path / "out/m.png")[..., :3]
    grey = np.all(np.abs(image - plt.matplotlib.colors.to_rgb(style.FORBIDDEN_COLOR)) < 0.01, axis=-1)
    rows = np.flatnonzero(grey.sum(axis=1) > 100)
    columns = np.flatnonzero(grey.sum(axis=0) > 100)
    top, bottom, left, right = rows[0], rows[-1], columns[0], columns[-1]
    axis = np.linspace(-6.0, 6.0, 300)
    grid_x, grid_px = np.meshgrid(axis, axis, indexing="ij")
    colors = map_colors(tilted(grid_x, grid_px) / 2, grid_x**2 + grid_px**2 <= 2 * (E_C + 0.125))
    for i, j in ((40, 120), (150, 60), (150, 230), (260, 110), (60, 250), (250, 40), (5, 5), (290, 290)):
        row = round(bottom - (axis[j] + 6) / 12 * (bottom - top))
        column = round(left + (axis[i] + 6) / 12 * (right - left))
        np.testing.assert_allclose(image[row, column], colors[i, j], atol=0.02, err_msg=f"node {i, j}")


def quick_config():
    config = yaml.safe_load((ROOT / "config.yaml").read_text())
    quick = yaml.safe_load((ROOT / "config.quick.yaml").read_text())

    def merge(base: dict, over: dict) -> None:  # Snakemake's merge of --configfile over configfile: recursive
        for key, value in over.items():
            if isinstance(value, dict) and isinstance(base.get(key), dict):
                merge(base[key], value)
            else:
                base[key] = value

    merge(config, quick)
    return validate_config(config)


def test_each_paper_figure_draws_only_the_stage_files_it_needs():
    config = load_config(ROOT / "config.yaml")
    assert figure_input_files(config, "fig1") == {"equilibria": ["results/barbanis_2dof/equilibria.nc"]}
    fig4 = figure_input_files(config, "fig4")
    assert sorted(fig4) == ["ld_maps", "upo"]  # no Poincaré sections, no manifolds
    assert fig4["upo"] == ["results/upo/barbanis_2dof_bottom.nc"]
    assert sorted(figure_input_files(config, "fig5")) == ["ld_maps"]
    assert figure_input_files(config, "fig3")["manifolds"] == [
        "results/manifolds/barbanis_2dof_bottom_dE0.125.nc", "results/manifolds/barbanis_2dof_top_dE0.125.nc"]
    # Every LD map a figure draws at this energy is fixed time for fig3 and variable time for fig4/fig5.
    for name, mode in (("fig3", "fixed"), ("fig4", "variable"), ("fig5", "variable")):
        assert {config["ld_maps"][m]["time"] for m in config["figures"][name]["ld_maps"]} == {mode}


def test_captions_state_the_parameters_used_and_render_as_html():
    config = quick_config()
    caption = figure_caption(config, "fig4")
    text = "\n".join(caption["lines"])
    assert "q_s = [4.5, 6.5] × [−8.5, −5.5]" in text  # the 2 DoF saddle region the paper leaves unstated
    assert "48 × 48 grid" in text  # the quick run's cap, not the configured 1500
    assert "τ = 50" in text and "ΔE = 0.125" in text
    henon = figure_caption(config, "henon_heiles_potential")["lines"][0]
    assert "V = (x^2 + y^2)/2 + lam·(x^2·y - y^3/3)" in henon  # no '*', which is emphasis markup
    for name in config["figures"]:
        parameters = figure_parameters(config, name)
        json.dumps(parameters)  # Snakemake compares params as text: they must be plain data
        template = (ROOT / "workflow/report" / f"{parameters['kind']}.rst").read_text()
        rst = jinja2.Template(template).render(snakemake=SimpleNamespace(params=SimpleNamespace(figure=parameters)))
        html = publish_parts(rst, writer="html", settings_overrides={"report_level": 2})["body"]
        assert "System Message" not in html, html  # docutils found nothing to complain about
        assert html.count("<li>") == len(parameters["caption"]["lines"])  # one list item per parameter line


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (lambda f: f["fig4"].update(ld_maps=["nope"]), "config key 'figures.fig4.ld_maps': no ld_maps entry 'nope'"),
        (lambda f: f["fig4"]["orbit"].update(energy={"excess": 0.2}), "config key 'figures.fig4.orbit.energy'"),
        (lambda f: f["fig1"].pop("energies"), "config key 'figures.fig1': a figure of kind 'potential' needs ['energies']"),
        (lambda f: f["fig2"].update(fixed={}), "config key 'figures.fig2.plane'"),
        (lambda f: f["fig3"]["manifold_curves"].update({"fig4_k-7.0": []}), "config key 'figures.fig3.manifold_curves.fig4_k-7.0'"),
        (lambda f: f["fig5"].update(kind="histogram"), "config key 'figures.fig5.kind'"),
    ],
)
def test_bad_figure_entries_name_the_key(change, message):
    config = yaml.safe_load((ROOT / "config.yaml").read_text())
    change(config["figures"])
    with pytest.raises(ConfigError, match=re.escape(message)):
        validate_config(config)


@pytest.mark.slow
def test_named_figure_targets_plan_only_their_stages(workdir):
    def planned(target):
        result = run_snakemake(workdir, target, "-n", "--quiet", "rules", timeout=300)
        assert result.returncode == 0, result.stderr
        return job_counts(result.stdout)

    assert planned("fig1") == {"equilibria": 1, "fig1": 1}  # two jobs in all
    fig4 = planned("fig4")
    # Fig. 4's three maps have one tile each (config.yaml): one ld_map job apiece, no gather
    assert "poincare" not in fig4 and "manifolds" not in fig4 and fig4["ld_map"] == 3 and "ld_gather" not in fig4
    fig3 = planned("fig3")
    assert fig3["poincare"] == 3 and fig3["manifolds"] == 2 and fig3["ld_gather"] == 3
