"""Tick labels a reader can read: no two labels of one axis overlap, no number is longer than
:data:`LONGEST` characters as drawn (mathtext markup taken out), and a logarithmic axis has at
least two (one label does not give the scale)."""

import re

#: The longest tick label drawn, in characters: '−1.5×10⁻¹²' is 10.
LONGEST = 12


def displayed(text: str) -> str:
    """A tick label's text as drawn: mathtext's markup (``$``, ``\\mathdefault``, braces, ``^``) taken out."""
    text = text.replace("$", "").replace(r"\mathdefault", "").replace(r"\times", "×").replace(r"\minus", "−")
    return re.sub(r"[{}^_\\]", "", text)


def is_number(text: str) -> bool:
    """Whether a label is a number (``2×10−3``, ``1e-05``, ``−0.25``), not a name such as a slice's:
    the length rule is for numbers, whose labels run into each other when a formatter misjudges."""
    return re.search(r"\d", text) is not None and re.search(r"[A-DF-Za-df-z]", text) is None


def _labels_in_view(axis) -> list:
    low, high = sorted(axis.get_view_interval())
    slack = 1e-9 * abs(high - low)
    labels = []
    for locations, ticks in ((axis.get_majorticklocs(), axis.get_major_ticks),
                             (axis.get_minorticklocs(), axis.get_minor_ticks)):
        for location, tick in zip(locations, ticks(len(locations))):
            if low - slack <= location <= high + slack:
                labels += [label for label in (tick.label1, tick.label2) if label.get_visible() and label.get_text()]
    return labels


def tick_label_problems(figure) -> list[str]:
    """What is wrong with the tick labels of every axes of ``figure`` (colour bars and 3-D axes
    included), drawn as it is: overlapping pairs (their window extents after drawing), labels
    longer than :data:`LONGEST` characters, logarithmic axes with fewer than two labels."""
    if not hasattr(figure.canvas, "get_renderer"):  # a closed figure (save_figure closes it) has a bare canvas
        from matplotlib.backends.backend_agg import FigureCanvasAgg

        FigureCanvasAgg(figure)
    figure.canvas.draw()
    renderer = figure.canvas.get_renderer()
    problems = []
    for index, ax in enumerate(figure.axes):
        for name in ("x", "y", "z"):
            axis = getattr(ax, f"{name}axis", None)
            if axis is None:
                continue
            labels = _labels_in_view(axis)
            boxes = [label.get_window_extent(renderer) for label in labels]
            texts = [displayed(label.get_text()) for label in labels]
            if axis.get_scale() == "log" and ax.get_visible() and axis.get_visible() and len(labels) < 2:
                problems.append(f"axes {index} ({ax.get_title(loc='left')}) {name}: a logarithmic axis with "
                                f"{len(labels)} labels (it needs two to be read)")
            problems += [f"axes {index} ({ax.get_title(loc='left')}) {name}: {text!r} is longer than {LONGEST} "
                         "characters" for text in texts if len(text) > LONGEST and is_number(text)]
            problems += [f"axes {index} ({ax.get_title(loc='left')}) {name}: {texts[i]!r} overlaps {texts[j]!r}"
                         for i in range(len(labels)) for j in range(i + 1, len(labels)) if boxes[i].overlaps(boxes[j])]
    return problems


def assert_readable_tick_labels(figure, folder) -> None:
    """Save ``figure`` as the pipeline saves a figure (:func:`ldpipe.figures.style.save_figure`, into
    ``folder``) and check its tick labels as saved."""
    from ldpipe.figures import style

    style.save_figure(figure, folder / "tick_labels.png")
    problems = tick_label_problems(figure)
    assert not problems, "\n".join(problems)


def record_saved_figures(monkeypatch) -> list:
    """The figures :func:`ldpipe.figures.style.save_figure` saves from now on in the test, in order
    (the ``draw_*`` functions that write their figure and return only its paths)."""
    from ldpipe.figures import style

    saved = []
    original = style.save_figure

    def recording(figure, *args, **kwargs):
        saved.append(figure)
        return original(figure, *args, **kwargs)

    monkeypatch.setattr(style, "save_figure", recording)
    return saved


def assert_saved_tick_labels_readable(figures: list) -> None:
    """Check the tick labels of figures already saved (:func:`record_saved_figures`); at least one."""
    assert figures, "no figure was saved"
    problems = [problem for figure in figures for problem in tick_label_problems(figure)]
    assert not problems, "\n".join(problems)
