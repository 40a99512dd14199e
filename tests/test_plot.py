"""``ds.ldpipe.plot()``: any variable of a map, drawn as xarray's own ``.plot(x=first axis)``
draws it (the map's first axis across, as the workflow's figures draw it), its missing points grey, matplotlib's keywords honoured, axes and colour bar labelled with units."""

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402
from matplotlib.colors import LogNorm, to_rgba  # noqa: E402

import ldpipe  # noqa: E402
from ldpipe.errors import ConfigError  # noqa: E402
from ldpipe.figures.style import FORBIDDEN_COLOR, draw_map  # noqa: E402
from support.henon_heiles import HENON_HEILES  # noqa: E402


@pytest.fixture(scope="module")
def hh_map():
    """The API tests' Hénon–Heiles map (the same engine module): it has forbidden points."""
    hh = ldpipe.system(name="henon_heiles", **HENON_HEILES)
    section = ldpipe.section(y=(-0.45, 0.8, 11), py=(-0.5, 0.5, 9), fixed={"px": 0.0}, solve="x", root="largest")
    return ldpipe.ld_map(hh, name="hh", section=section, energy=0.125, tau=2.0,
                         integrator={"scheme": "dop853", "rtol": 1e-8, "atol": 1e-8})


@pytest.fixture
def axes():
    figure, pair = plt.subplots(1, 2)
    yield pair
    plt.close(figure)


def _mesh(ax):
    (mesh,) = ax.collections
    return mesh


@pytest.mark.parametrize("variable", ["ld_forward", "exit_time_backward", "allowed"])
def test_any_variable_is_drawn_as_xarray_draws_it(hh_map, axes, variable):
    """The same cells, the map's first axis (the section's first coordinate, y) horizontal, the
    same values: the two QuadMeshes agree (a transposed drawing would swap the coordinates and
    the array's shape)."""
    assert hh_map[variable].dims[0] == "y"
    theirs = hh_map[variable].astype(float).plot(ax=axes[0], x="y", add_colorbar=False)
    assert hh_map.ldpipe.plot(variable, ax=axes[1]) is axes[1]
    ours = _mesh(axes[1])
    np.testing.assert_array_equal(ours.get_coordinates(), theirs.get_coordinates())
    np.testing.assert_array_equal(np.ma.masked_invalid(ours.get_array()), np.ma.masked_invalid(theirs.get_array()))
    assert axes[0].get_xlim() == axes[1].get_xlim() and axes[0].get_ylim() == axes[1].get_ylim()


def test_missing_points_are_grey_and_the_labels_carry_units(hh_map, axes):
    """Forbidden points (NaN, 'allowed' false) are painted the figures' neutral grey, not the lowest
    colour; the axes are the section's coordinates, the colour bar the LD, each with its units."""
    field = hh_map.ld_forward + hh_map.ld_backward
    with_units = hh_map.copy()
    with_units["ld_forward"].attrs["units"] = with_units["ld_backward"].attrs["units"] = "km"  # as on the sphere
    with_units["py"].attrs["units"] = "m/s"
    with_units.ldpipe.plot(ax=axes[0])  # the default: forward plus backward
    mesh = _mesh(axes[0])
    rows = field.shape[::-1]  # the mesh's rows run along the vertical axis, the map's second
    drawn = np.ma.masked_invalid(mesh.get_array()).reshape(rows)
    np.testing.assert_allclose(drawn.filled(np.nan), field.values.T, rtol=0, atol=0)
    colours = mesh.to_rgba(mesh.get_array()).reshape(rows + (4,))
    forbidden = ~hh_map.allowed.values.T
    assert forbidden.any()
    np.testing.assert_array_equal(colours[forbidden], np.tile(to_rgba(FORBIDDEN_COLOR), (forbidden.sum(), 1)))
    assert not np.any(np.all(colours[~forbidden] == to_rgba(FORBIDDEN_COLOR), axis=-1))
    assert axes[0].get_xlabel() == "$y$" and axes[0].get_ylabel() == "$p_y$ [m/s]"
    colorbar_axes = [ax for ax in axes[0].figure.axes if ax not in axes]
    assert [ax.get_ylabel() for ax in colorbar_axes] == [r"$\mathcal{L}$ [km]"]


def test_matplotlib_keywords_are_honoured(hh_map, axes):
    hh_map.ldpipe.plot("ld_backward", ax=axes[0], cmap="magma", vmin=1.0, vmax=2.0, add_colorbar=False)
    mesh = _mesh(axes[0])
    assert mesh.get_clim() == (1.0, 2.0) and mesh.cmap.name.startswith("magma")
    assert len(axes[0].figure.axes) == 2  # no colour bar
    norm = LogNorm(1.0, 5.0)
    hh_map.ldpipe.plot("ld_backward", ax=axes[1], norm=norm, x="py")
    assert _mesh(axes[1]).norm is norm
    assert axes[1].get_xlabel() == "$p_y$" and axes[1].get_ylabel() == "$y$"  # x= chooses the horizontal one


def test_bad_plot_arguments_name_what_exists(hh_map):
    with pytest.raises(ConfigError, match=r"no variable 'ftle_forward'; it has \[.*'ld_forward'"):
        hh_map.ldpipe.plot("ftle_forward")
    with pytest.raises(ConfigError, match="x='z'"):
        hh_map.ldpipe.plot(x="z")
    plt.close("all")


def test_the_notebook_picture_is_the_workflows(hh_map, axes):
    """ds.ldpipe.plot() and the workflow's figures (style.draw_map, which every LD figure uses)
    put the same coordinate across and the same values in the same places: the image's extent
    spans the mesh's cells, and the value at a cell's centre is the mesh's there."""
    field = (hh_map.ld_forward + hh_map.ld_backward).values
    image = draw_map(axes[0], hh_map.y.values, hh_map.py.values, np.ma.masked_invalid(field), limits=(0.0, 1.0))
    hh_map.ldpipe.plot(ax=axes[1])
    corners = _mesh(axes[1]).get_coordinates()  # (rows + 1, columns + 1, 2): x, y of the cells' corners
    left, right, bottom, top = image.get_extent()
    np.testing.assert_allclose([corners[..., 0].min(), corners[..., 0].max()], [left, right], rtol=1e-12)
    np.testing.assert_allclose([corners[..., 1].min(), corners[..., 1].max()], [bottom, top], rtol=1e-12)
    drawn = np.ma.masked_invalid(_mesh(axes[1]).get_array()).reshape(corners.shape[0] - 1, corners.shape[1] - 1)
    np.testing.assert_array_equal(drawn.filled(np.nan), np.asarray(image.get_array().filled(np.nan)))
