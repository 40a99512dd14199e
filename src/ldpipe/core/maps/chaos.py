"""Chaos indicators of a discrete map from its LD, beside the fast Lyapunov indicator.

The LD of an orbit on an invariant torus changes smoothly with its start; near a chaotic orbit
it changes as fast as neighbouring orbits separate. Hillebrand et al. (2022) turn the LDs of a
start x and of its 2n neighbours x +- sigma e_i (n the map's dimension) into indicators, with
L = ld_forward + ld_backward (M_p over n from -N to N-1):

- the difference D_L^n(x) = (1 / 2n) sum over the neighbours y of |L(y) - L(x)| / L(x);
- the second difference S_L^n(x) = (1 / n) sum_i |L(x + sigma e_i) - 2 L(x) + L(x - sigma e_i)| / L(x);

and Daquin et al. (2022) the Laplacian |Delta L|(x), here by the same neighbours:
|sum_i (L(x + sigma e_i) - 2 L(x) + L(x - sigma e_i))| / sigma^2. Each is small on regular
orbits and grows exponentially with N on chaotic ones.

The reference is the fast Lyapunov indicator FLI = max_{n <= N'} log10 |w_n| of a deviation
vector carried by the tangent map (:func:`ldpipe.engine.discrete_map.fast_lyapunov_indicator`)
over a longer N': a regular orbit's deviations grow linearly, so FLI <= 2 log10 N' counts as
regular, more as chaotic. An indicator's own threshold is Otsu's on the log10 of its values
(the split of their histogram that maximises the variance between its two parts), which reads
nothing of the reference; the agreement is the fraction of starts both call alike.
"""

from __future__ import annotations

import numpy as np
import xarray as xr

from ...engine.discrete_map import fast_lyapunov_indicator, iterate_map_ld

#: The indicators from the LD, by their variable's name, with what each is.
INDICATORS = {
    "ld_difference": "D_L^n: the mean |L(y) - L(x)| / L(x) over the 2n neighbours y = x +- sigma e_i "
                     "(Hillebrand et al. 2022)",
    "ld_second_difference": "S_L^n: the mean over the n axes of |L(x + sigma e_i) - 2 L(x) + L(x - sigma e_i)| / L(x) "
                            "(Hillebrand et al. 2022)",
    "ld_laplacian": "|Delta L|: |sum_i (L(x + sigma e_i) - 2 L(x) + L(x - sigma e_i))| / sigma^2 "
                    "(Daquin et al. 2022)",
}


def total_ld(system, states: np.ndarray, iterations: int, p: float, escape_radius: float) -> tuple[np.ndarray,
                                                                                                    np.ndarray]:
    """L = forward + backward half of the discrete LD of each start, and whether either orbit escaped."""
    forward = iterate_map_ld(system, states, iterations, p, 1, escape_radius)
    backward = iterate_map_ld(system, states, iterations, p, -1, escape_radius)
    return forward.ld + backward.ld, forward.escaped | backward.escaped


def ld_indicators(system, states: np.ndarray, iterations: int, p: float, sigma: float,
                  escape_radius: float) -> dict[str, np.ndarray]:
    """The LD, its indicators (:data:`INDICATORS`) at each row of ``states`` from the LDs of the
    2n neighbours at distance ``sigma``, and ``defined``: L(x) > 0 and no orbit of the 2n + 1
    escaped (elsewhere the indicators are 0)."""
    if not sigma > 0:
        raise ValueError(f"sigma: expected a positive distance, got {sigma!r}")
    n = system.n_state
    centre, escaped = total_ld(system, states, iterations, p, escape_radius)
    pairs = []
    for axis in range(n):
        offset = np.zeros(n)
        offset[axis] = sigma
        plus, escaped_plus = total_ld(system, states + offset, iterations, p, escape_radius)
        minus, escaped_minus = total_ld(system, states - offset, iterations, p, escape_radius)
        escaped |= escaped_plus | escaped_minus
        pairs.append((plus, minus))
    return neighbour_indicators(centre, pairs, sigma, ~escaped)


def neighbour_indicators(centre: np.ndarray, pairs: list[tuple[np.ndarray, np.ndarray]], sigma: float,
                         usable: np.ndarray) -> dict[str, np.ndarray]:
    """The indicators of :data:`INDICATORS` from the LD ``centre`` at each start and ``pairs``, the
    LDs (L(x + sigma e_i), L(x - sigma e_i)) at its neighbours along each axis i, with ``ld`` and
    ``defined`` (``usable`` and L(x) > 0; the indicators are 0 elsewhere)."""
    n = len(pairs)
    first = np.zeros_like(centre)
    second = np.zeros_like(centre)
    laplacian = np.zeros_like(centre)
    for plus, minus in pairs:
        first += np.abs(plus - centre) + np.abs(minus - centre)
        curvature = plus - 2 * centre + minus
        second += np.abs(curvature)
        laplacian += curvature
    defined = (centre > 0) & usable
    scale = np.where(defined, centre, 1.0)
    return {
        "ld": centre,
        "ld_difference": np.where(defined, first / (2 * n * scale), 0.0),
        "ld_second_difference": np.where(defined, second / (n * scale), 0.0),
        "ld_laplacian": np.where(defined, np.abs(laplacian) / sigma**2, 0.0),
        "defined": defined,
    }


def otsu_threshold(values: np.ndarray, bins: int = 256) -> float:
    """The threshold splitting ``values`` in two classes of the largest variance between them
    (Otsu 1979), on a histogram of ``bins`` bins; in the middle of an empty stretch between them."""
    counts, edges = np.histogram(values, bins=bins)
    centres = (edges[:-1] + edges[1:]) / 2
    below = np.cumsum(counts)[:-1]
    above = counts.sum() - below
    mass = np.cumsum(counts * centres)[:-1]
    total = float(np.sum(counts * centres))
    keep = (below > 0) & (above > 0)
    between = np.zeros(len(below))
    between[keep] = below[keep] * above[keep] * (mass[keep] / below[keep] - (total - mass[keep]) / above[keep]) ** 2
    # an empty stretch of the histogram between the classes ties: take the middle of it
    best = np.flatnonzero(between >= between.max() * (1 - 1e-12))
    return float((edges[best[0] + 1] + edges[best[-1] + 1]) / 2)


def minimum_error_threshold(values: np.ndarray, bins: int = 256) -> float:
    """The threshold of least classification error when ``values`` are two normal classes, each
    with its own mean and spread (Kittler and Illingworth 1986): the histogram edge k minimizing
    J(k) = P_1 ln s_1 + P_2 ln s_2 - P_1 ln P_1 - P_2 ln P_2 (P_i the classes' shares, s_i their
    standard deviations). Otsu's criterion assumes equal spreads and cuts into the wider class
    when one is several times wider than the other; this one does not."""
    counts, edges = np.histogram(values, bins=bins)
    centres = (edges[:-1] + edges[1:]) / 2
    below = np.cumsum(counts)[:-1].astype(float)
    above = counts.sum() - below
    first = np.cumsum(counts * centres)[:-1]
    second = np.cumsum(counts * centres**2)[:-1]
    total_first, total_second = float(np.sum(counts * centres)), float(np.sum(counts * centres**2))
    keep = (below > 1) & (above > 1)
    criterion = np.full(len(below), np.inf)
    low, high = below[keep], above[keep]
    variance_low = second[keep] / low - (first[keep] / low) ** 2
    variance_high = (total_second - second[keep]) / high - ((total_first - first[keep]) / high) ** 2
    spread = (variance_low > 0) & (variance_high > 0)
    share = low / (low + high)
    with np.errstate(divide="ignore", invalid="ignore"):
        value = (share * np.log(variance_low) / 2 + (1 - share) * np.log(variance_high) / 2
                 - share * np.log(share) - (1 - share) * np.log(1 - share))
    criterion[np.flatnonzero(keep)[spread]] = value[spread]
    if not np.isfinite(criterion).any():
        return otsu_threshold(values, bins)
    return float(edges[int(np.argmin(criterion)) + 1])


def regular_fli_bound(reference_iterations: int) -> float:
    """The largest FLI counted regular after N' iterations: 2 log10 N' (deviations growing
    linearly reach about log10 N')."""
    return 2 * float(np.log10(reference_iterations))


def classify(indicators: dict[str, np.ndarray], defined: np.ndarray, fli: np.ndarray | None,
             reference_iterations: int | None) -> tuple[dict[str, np.ndarray], dict[str, float]]:
    """Each indicator's classification (chaotic where log10 of it is above its Otsu threshold,
    among the ``defined`` starts), and as attributes the thresholds and, with the ``fli`` over
    ``reference_iterations``, each one's agreement with the FLI's classification."""
    reference = None if fli is None else fli > regular_fli_bound(reference_iterations)
    return classify_against(indicators, tuple(INDICATORS), defined, reference)


def classify_against(indicators: dict[str, np.ndarray], names: tuple[str, ...], defined: np.ndarray,
                     reference: np.ndarray | None, thresholds: dict | None = None
                     ) -> tuple[dict[str, np.ndarray], dict[str, float]]:
    """Each of the ``indicators`` ``names`` classified chaotic where log10 of it is above its
    threshold (among the ``defined`` starts where it is positive): Otsu's, or the function
    ``thresholds`` gives for the name; and as attributes the thresholds and, with a
    ``reference`` classification (True: chaotic), the fraction of those starts where each agrees
    with it (``agreement_<name>``)."""
    thresholds = thresholds or {}
    chaotic, attributes = {}, {}
    for name in names:
        values = indicators[name]
        logarithm = np.log10(np.where(defined & (values > 0), values, 1.0))
        usable = defined & (values > 0)
        split = thresholds.get(name, otsu_threshold)
        threshold = split(logarithm[usable]) if usable.any() else 0.0
        chaotic[name] = usable & (logarithm > threshold)
        attributes[f"threshold_log10_{name}"] = threshold
        if reference is not None and usable.any():
            attributes[f"agreement_{name}"] = float(np.mean(chaotic[name][usable] == reference[usable]))
    return chaotic, attributes


def chaos_indicators(system, states: np.ndarray, *, iterations: int, sigma: float, reference_iterations: int,
                     p: float = 0.5, escape_radius: float = 100.0) -> xr.Dataset:
    """The LD indicators of ``states`` (one row a start) beside the FLI over ``reference_iterations``,
    each indicator's classification (chaotic above its Otsu threshold of log10 values) and its
    agreement with the FLI's, over the starts where everything is defined (a Dataset over
    ``start``; thresholds and agreements in its attributes)."""
    states = np.ascontiguousarray(states, dtype=float)
    found = ld_indicators(system, states, iterations, p, sigma, escape_radius)
    fli, fli_escaped = fast_lyapunov_indicator(system, states, reference_iterations, escape_radius)
    defined = found["defined"] & ~fli_escaped
    bound = regular_fli_bound(reference_iterations)
    reference = fli > bound
    variables = {
        "state": (("start", "coordinate"), states, {"long_name": "start of the orbit"}),
        "ld": (("start",), found["ld"], {"long_name": "discrete LD, forward and backward halves summed"}),
        "fli": (("start",), fli, {"long_name": f"fast Lyapunov indicator over {reference_iterations} iterations"}),
        "chaotic_fli": (("start",), reference & defined, {"long_name": f"chaotic by the FLI (above {bound:g})"}),
        "defined": (("start",), defined, {"long_name": "L > 0 and no orbit of the start or its neighbours escaped"}),
    }
    attributes = {"iterations": iterations, "p": p, "sigma": sigma, "reference_iterations": reference_iterations,
                  "fli_regular_bound": bound, "escape_radius": escape_radius, "defined_starts": int(defined.sum())}
    chaotic, classified = classify(found, defined, fli, reference_iterations)
    for name, text in INDICATORS.items():
        variables[name] = (("start",), found[name], {"long_name": text, "comment": "0 where not defined"})
        variables[f"chaotic_{name}"] = (("start",), chaotic[name], {"long_name": f"chaotic by {name} (log10 above "
                                                                                 "its Otsu threshold)"})
    return xr.Dataset(variables, coords={"coordinate": list(system.coordinates)}, attrs={**attributes, **classified})


def add_map_classification(dataset: xr.Dataset) -> None:
    """A whole map file's classifications by its indicators (``chaotic_<indicator>``) and their
    thresholds and agreements with its FLI, where it holds one, as attributes
    (:func:`classify`): of the whole map, so after its tiles are gathered."""
    if "ld_difference" not in dataset:
        return
    dims = dataset.allowed.dims
    defined = dataset.indicator_defined.values
    fli = dataset.fli.values if "fli" in dataset else None
    if fli is not None:
        defined = defined & ~dataset.fli_escaped.values
    chaotic, attributes = classify({name: dataset[name].values for name in INDICATORS}, defined, fli,
                                   dataset.attrs.get("fli_iterations"))
    for name in INDICATORS:
        dataset[f"chaotic_{name}"] = (dims, chaotic[name], {"long_name": f"chaotic by {name} (log10 above its Otsu "
                                                                          "threshold over the whole map)"})
    dataset.attrs.update(attributes)
