"""Figures of the paper and of parameter studies, drawn from stage files.

One module per figure kind (``potential``, ``section_maps``, ``ld_slices``, ``orbit_family``),
a shared look in :mod:`ldpipe.figures.style` and the readers of stage files in
:mod:`ldpipe.figures.data`. Which figures exist, and what they draw, is configuration
(``figures:`` in config.yaml); :mod:`ldpipe.stages.figures` turns an entry into one call.
"""
