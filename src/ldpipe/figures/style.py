"""One look for every figure: the paper's symbols, colour maps, colour bars, rasterized maps, saving.

Every figure module draws through these helpers so that axes carry the paper's symbols
($x$, $p_x$, $\\mathcal{L}$ ...), LD maps share one colour map with the energetically
forbidden region in grey (never drawn as LD = 0), and each figure is written once as PNG
(for browsing and the report) and once as PDF with the dense maps rasterized inside it, so
that neither file grows with the grid size.
"""

from __future__ import annotations

import contextlib
import math
from pathlib import Path
from typing import Callable, Iterator

import sys

import matplotlib

if "matplotlib.pyplot" not in sys.modules:
    # Figures are files; never open a window (Snakemake jobs have no display). A session that
    # already draws (a notebook, through ds.ldpipe.plot) keeps its backend and its figures.
    matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.colors import Colormap  # noqa: E402
from matplotlib.ticker import MaxNLocator, NullFormatter  # noqa: E402

from ..io.atomic import atomic_path  # noqa: E402
from ..io.datafile import open_stage_file  # noqa: E402

#: Colour map of every LD map; forbidden points (masked) are drawn in FORBIDDEN_COLOR.
LD_COLORMAP = "viridis"
FORBIDDEN_COLOR = "0.82"
#: The paper's colours: stable manifolds cyan, unstable magenta (Fig. 3(f)), the energy boundary
#: of a Poincaré section green (Fig. 3(a-c)), the slices orange and the periodic orbit black (Fig. 4(d)),
#: the saddles red crosses (Fig. 1).
STABLE_COLOR = "cyan"
UNSTABLE_COLOR = "magenta"
BOUNDARY_COLOR = "green"
SLICE_COLOR = "darkorange"
ORBIT_COLOR = "black"
SADDLE_COLOR = "red"
HILL_COLOR = "0.75"
#: Colours of successive 1D slices (each slice line on a map has its curve's colour).
SLICE_COLORS = ("tab:red", "tab:blue", "tab:green", "tab:purple", "tab:brown", "tab:pink")
#: Resolution of the PNG files and of the rasterized maps inside the PDF files.
DPI = 150

RC_PARAMS = {
    "font.size": 9,
    "axes.titlesize": 9,
    "axes.labelsize": 10,
    "xtick.labelsize": 8,
    "ytick.labelsize": 8,
    "legend.fontsize": 7,
    "figure.dpi": DPI,
    "savefig.dpi": DPI,
    "image.origin": "lower",
    "mathtext.fontset": "cm",
    "axes.formatter.useoffset": False,
}


@contextlib.contextmanager
def figure_style() -> Iterator[None]:
    """Apply ldpipe's style to the figures created inside the block."""
    with plt.rc_context(RC_PARAMS):
        yield


def symbol(name: str) -> str:
    """The paper's symbol of a phase-space coordinate as mathtext: 'px' -> '$p_x$', 'y' -> '$y$'."""
    if len(name) > 1 and name.startswith("p"):
        index = name[1:] if len(name) == 2 else f"{{{name[1:]}}}"
        return f"$p_{index}$"
    return f"${name}$"


def position_text(values) -> str:
    """A point's coordinates for a title, ``(20.17, 0)``: four significant digits, and 0 for a
    coordinate that is zero to rounding, as a saddle's coordinate on a symmetry plane comes out of
    its root search: subnormal (what is left of an underflow, 1e-310), or within half a rounding
    unit of the largest coordinate (added to it, nothing changes: 3e-17 beside 20.17)."""
    values = np.atleast_1d(np.asarray(values, dtype=float))
    magnitudes = np.abs(values)
    scale = magnitudes.max(initial=0.0)
    zero = (magnitudes < np.finfo(float).tiny) | (magnitudes <= 0.5 * np.finfo(float).eps * scale)
    return "(" + ", ".join("0" if nil else f"{value:.4g}" for value, nil in zip(values, zero)) + ")"


def section_symbol(axes: tuple[str, str], sign: int | None = None) -> str:
    """The paper's name of a section with these axes, e.g. '$U_{xp_x}^+$'."""
    subscript = "".join(a if len(a) == 1 else f"p_{{{a[1:]}}}" for a in axes)
    superscript = {1: "^+", -1: "^-"}.get(sign, "")
    return f"$U_{{{subscript}}}{superscript}$"


#: Label of the Lagrangian descriptor (forward plus backward unless said otherwise).
LD_LABEL = {
    "total": r"$\mathcal{L}$",
    "forward": r"$\mathcal{L}^{f}$",
    "backward": r"$\mathcal{L}^{b}$",
}


def ld_colormap() -> Colormap:
    """The LD colour map, with masked (energetically forbidden) points in grey."""
    return plt.get_cmap(LD_COLORMAP).with_extremes(bad=FORBIDDEN_COLOR)


def color_limits(values: np.ndarray, percentiles: tuple[float, float]) -> tuple[float, float]:
    """Colour-scale limits: the given percentiles of the unmasked values (a robust range, so that
    a few extreme points do not wash out the structure). Returns (0, 1) if nothing is unmasked."""
    data = np.ma.compressed(np.ma.masked_invalid(values))
    if data.size == 0:
        return 0.0, 1.0
    low, high = np.percentile(data, percentiles)
    if not high > low:
        high = low + max(abs(low) * 1e-6, 1e-12)
    return float(low), float(high)


def draw_map(ax, first: np.ndarray, second: np.ndarray, values: np.ma.MaskedArray, *,
             limits: tuple[float, float], colorbar_label: str | None = None):
    """Draw a map over a regular grid, rasterized in vector output, with a colour bar.

    Parameters
    ----------
    ax : matplotlib Axes
    first, second : ndarray, shapes (n1,), (n2,)
        Grid coordinates along the horizontal and the vertical axis (regular spacing).
    values : masked ndarray, shape (n1, n2)
        The field; masked points are drawn in grey (the forbidden region).
    limits : (float, float)
        Colour-scale limits.
    colorbar_label : str, optional
        Label of the colour bar; None for no colour bar.

    Returns
    -------
    The image (a matplotlib AxesImage).
    """
    dx = (first[-1] - first[0]) / max(len(first) - 1, 1)
    dy = (second[-1] - second[0]) / max(len(second) - 1, 1)
    extent = (first[0] - dx / 2, first[-1] + dx / 2, second[0] - dy / 2, second[-1] + dy / 2)
    image = ax.imshow(
        np.ma.transpose(values), extent=extent, origin="lower", aspect="auto", cmap=ld_colormap(),
        vmin=limits[0], vmax=limits[1], interpolation="nearest", rasterized=True,
    )
    if colorbar_label is not None:
        colorbar = ax.figure.colorbar(image, ax=ax, fraction=0.046, pad=0.03)
        colorbar.set_label(colorbar_label)
    return image


def label_axes(ax, horizontal: str, vertical: str) -> None:
    """Label an axes with the paper's symbols of two phase-space coordinates."""
    ax.set_xlabel(symbol(horizontal))
    ax.set_ylabel(symbol(vertical))


def panel_letter(ax, index: int, text: str = "") -> None:
    """The panel's letter, (a), (b), ..., in its top left corner as the paper labels panels,
    followed by ``text`` (what the panel shows)."""
    ax.set_title(f"({chr(ord('a') + index)}) {text}".rstrip(), loc="left")


def readable_ticks(figure) -> None:
    """Tick labels that do not run into each other, on every axes of ``figure``.

    A logarithmic axis labels its decades, and only them: left to itself matplotlib labels minor
    ticks too when an axis spans less than about two decades (2×10⁻¹, 3×10⁻¹, 4×10⁻¹ ...), and
    on a narrow panel those labels overlap. An axis spanning less than a decade is widened to the
    decades around its data, so it keeps two labels. An axis of a 3-D panel, foreshortened by the
    view, keeps fewer ticks until its labels stand apart, and none if even two would touch.
    """
    for ax in figure.axes:
        if ax.name == "3d":
            continue
        colorbar = getattr(ax, "_colorbar", None) is not None
        for axis, limits, set_limits in ((ax.xaxis, ax.get_xlim, ax.set_xlim), (ax.yaxis, ax.get_ylim, ax.set_ylim)):
            if axis.get_scale() != "log":
                continue
            axis.set_minor_formatter(NullFormatter())
            low, high = sorted(limits())
            if colorbar or not low > 0:
                continue
            first, last = math.log10(low), math.log10(high)
            if math.floor(last + 1e-9) - math.ceil(first - 1e-9) >= 1:  # two decades labelled already
                continue
            below, above = math.floor(first + 1e-9), math.ceil(last - 1e-9)
            widened = (10.0**below, 10.0 ** max(above, below + 1))
            set_limits(widened if limits()[0] <= limits()[1] else widened[::-1])
    for ax in figure.axes:
        if ax.name == "3d":
            for axis in (ax.xaxis, ax.yaxis, ax.zaxis):
                _thin_labels(figure, axis)


def _overlapping(figure, axis) -> bool:
    """Whether two of ``axis``'s tick labels in view overlap, as ``figure`` is drawn."""
    figure.canvas.draw()
    renderer = figure.canvas.get_renderer()
    low, high = sorted(axis.get_view_interval())
    locations = axis.get_majorticklocs()
    boxes = [tick.label1.get_window_extent(renderer) for location, tick in zip(locations, axis.get_major_ticks(len(locations)))
             if low <= location <= high and tick.label1.get_visible() and tick.label1.get_text()]
    return any(a.overlaps(b) for i, a in enumerate(boxes) for b in boxes[i + 1:])


def _thin_labels(figure, axis) -> None:
    """Fewer ticks on ``axis`` until their labels do not overlap; no labels if two still do."""
    if axis.get_scale() != "linear" or not hasattr(figure.canvas, "get_renderer"):
        return
    for bins in (4, 3, 2, 1):
        if not _overlapping(figure, axis):
            return
        axis.set_major_locator(MaxNLocator(bins))
    if _overlapping(figure, axis):
        axis.set_ticklabels([])


def save_figure(figure, png: str | Path, pdf: str | Path | None = None) -> list[Path]:
    """Write ``figure`` as PNG (and PDF, maps rasterized at :data:`DPI`), then close it.

    Its tick labels are made readable first (:func:`readable_ticks`). Both files are
    written under temporary names and renamed when complete, so a killed job never leaves a
    figure that looks finished.
    """
    readable_ticks(figure)
    written = []
    for path, kind in ((png, "png"), (pdf, "pdf")):
        if path is None:
            continue
        path = Path(path)
        with atomic_path(path) as temporary:
            figure.savefig(temporary, format=kind, dpi=DPI, bbox_inches="tight")
        written.append(path)
    plt.close(figure)
    return written


def study_drawing(figure_of: Callable, stage, what: str) -> Callable[..., list[Path]]:
    """The ``draw_*`` function of a one-study figure: ``draw(study=..., png=..., pdf=None)`` draws
    ``figure_of`` the file ``study`` of ``stage`` (a :class:`~ldpipe.io.contracts.StageFile`) and
    writes it to ``png`` (and ``pdf``); ``what`` names the study in its docstring."""

    def draw(*, study: str | Path, png: str | Path, pdf: str | Path | None = None) -> list[Path]:
        return save_figure(figure_of(open_stage_file(study, stage=stage)), png, pdf)

    draw.__name__ = draw.__qualname__ = f"draw_{stage.stage}"
    draw.__doc__ = f"Draw the figure of the {what} file ``study`` to ``png`` (and ``pdf``)."
    return draw


def finish_deviation_panel(ax, ylabel: str, title: str, letter: int) -> None:
    """Label a panel of relative deviations against the excess energy on log-log axes (the flux
    figures' comparison panels): scales, axis labels, title, legend and the panel's letter."""
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel(r"$\Delta E = E - E_c$")
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    ax.legend(loc="lower right", fontsize=7)
    panel_letter(ax, letter)


def plot_deviation(ax, x: np.ndarray, deviation: np.ndarray, marker: str, color, name: str, reference: str = "") -> None:
    """|deviation| against x for a log scale: ``marker`` where it is positive, hollow circles where
    negative, labelled "``name``, above (below) ``reference``" when there are any."""
    for sign, shape in ((1, marker), (-1, "o")):
        keep = np.sign(deviation) == sign
        ax.plot(x[keep], np.abs(deviation[keep]), shape, color=color, mfc="none", ms=8,
                label=f"{name}, {'above' if sign > 0 else 'below'}{' ' + reference if reference else ''}"
                if keep.any() else None)
