"""NHIM validation stage: the tables of the NHIM studies against their references, and the verdict.

It reads only the study files (:data:`ldpipe.io.contracts.NHIM`) and the orbit validation files
(:data:`ldpipe.io.contracts.NHIM_ORBITS`), so a change to the NHIM science or the engine reruns
those, and this stage only through their outputs. Two tables: the LD-map studies
(``validation``) and the slices through periodic-orbit points (``validation_orbits``).
"""

from __future__ import annotations

import csv
import io
from pathlib import Path

from ..io.atomic import check_writable, write_text_atomic
from ..io.contracts import NHIM, NHIM_ORBITS
from ..io.datafile import open_stage_file
from ..errors import LdpipeError
from ..logs import get_logger

log = get_logger(__name__)


class NHIMValidationError(LdpipeError):
    """A refined NHIM point is farther from its reference than the configured tolerance."""


TABLE_COLUMNS = (
    "study", "slice", "dE", "axes", "refined_a", "refined_b", "reference", "distance_refined", "distance_zoom",
    "distance_detected", "distance_argmax_sum", "refined_uncertainty", "residence_forward", "residence_backward",
    "neighbour_residence_max", "refined_ld_forward", "refined_ld_backward", "trajectories", "wall_time_s", "status",
)


def validation_rows(study_file: str | Path, tolerance: float, residence_ratio: float) -> list[dict]:
    """One table row per slice of a study file, with its pass/fail status."""
    data = open_stage_file(study_file, stage=NHIM)
    rows = []
    for k, name in enumerate(data.slice.values):
        get = lambda v: data[v].values[k]  # noqa: E731
        kind = str(get("reference_kind"))
        problems = []
        if kind == "orbit_crossing" and not get("distance_refined") <= tolerance:
            problems.append(f"distance to the periodic orbit's crossing {get('distance_refined'):.3g} > tolerance {tolerance:g}")
        residence = min(get("residence_forward"), get("residence_backward"))
        if not residence >= residence_ratio * get("neighbour_residence_max"):
            problems.append(f"residence {residence:.3g} < {residence_ratio:g} x neighbours' {get('neighbour_residence_max'):.3g}")
        rows.append({
            "study": str(data.attrs["study"]), "slice": str(name), "dE": float(get("excess_energy")),
            "axes": "-".join(str(a) for a in get("axis_names")),
            "refined_a": float(get("refined_point")[0]), "refined_b": float(get("refined_point")[1]),
            "reference": f"{kind}:{get('reference_family')}" if kind != "none" else "none",
            "distance_refined": float(get("distance_refined")),
            "distance_zoom": float(get("distance_zoom")) if get("zoom_converged") else "not converged",
            "distance_detected": float(get("distance_detected")), "distance_argmax_sum": float(get("distance_argmax_sum")),
            "refined_uncertainty": float(get("refined_uncertainty")),
            "residence_forward": float(get("residence_forward")), "residence_backward": float(get("residence_backward")),
            "neighbour_residence_max": float(get("neighbour_residence_max")),
            "refined_ld_forward": float(get("refined_ld_forward")), "refined_ld_backward": float(get("refined_ld_backward")),
            "trajectories": int(get("refined_trajectories")), "wall_time_s": float(get("refined_wall_time")),
            "status": "ok" if not problems else "FAIL: " + "; ".join(problems),
        })
    return rows


def _markdown(rows: list[dict], tolerance: float) -> str:
    fmt = _format
    lines = [
        "# NHIM points on LD maps against their references",
        "",
        f"Distances in section coordinates; validation tolerance {tolerance:g}. `refined`: bisection on fates; "
        "`zoom`: zoomed LD re-gridding; `detected`: grid point of largest min(F/F_ridge, B/B_ridge), each LD over the median of its per-row maxima; `argmax_sum`: "
        "grid point of largest F + B. Residence: time in the saddle region (forward, backward) of the refined point, "
        "and the largest min(forward, backward) of its 8 grid neighbours.",
        "",
        "| " + " | ".join(TABLE_COLUMNS) + " |",
        "|" + "---|" * len(TABLE_COLUMNS),
    ]
    lines += ["| " + " | ".join(fmt(row[c]) for c in TABLE_COLUMNS) + " |" for row in rows]
    return "\n".join(lines) + "\n"


ORBIT_COLUMNS = (
    "study", "family", "E", "phase", "axes", "solve", "orbit_a", "orbit_b", "solved_momentum", "boundary_distance",
    "transversality", "candidates", "crossings", "distance", "uncertainty", "trajectories", "wall_time_s", "status",
    "reason",
)


def orbit_validation_rows(study_file: str | Path) -> list[dict]:
    """One table row per slice of an orbit validation file (its status as the stage recorded it)."""
    data = open_stage_file(study_file, stage=NHIM_ORBITS)
    rows = []
    for k in range(data.sizes["slice"]):
        get = lambda v: data[v].values[k]  # noqa: E731
        rows.append({
            "study": str(data.attrs["study"]), "family": str(get("family")), "E": float(get("energy")),
            "phase": float(get("orbit_phase")), "axes": "-".join(str(a) for a in get("axis_names")),
            "solve": str(get("solve")), "orbit_a": float(get("orbit_point")[0]), "orbit_b": float(get("orbit_point")[1]),
            "solved_momentum": float(get("solved_momentum")), "boundary_distance": float(get("boundary_distance")),
            "transversality": float(get("transversality")), "candidates": int(get("candidates")),
            "crossings": int(get("crossings")),
            "distance": float(get("distance")) if get("distance") >= 0 else "none",
            "uncertainty": float(get("uncertainty")), "trajectories": int(get("trajectories")),
            "wall_time_s": float(get("wall_time")), "status": str(get("status")), "reason": str(get("reason")),
        })
    return rows


def _orbit_markdown(rows: list[dict], tolerances: dict[str, float]) -> str:
    counts = {}
    for row in rows:
        counts[row["status"]] = counts.get(row["status"], 0) + 1
    lines = [
        "# NHIM crossings of slices through periodic-orbit points",
        "",
        "Each slice fixes every coordinate but its two axes and the solved momentum at an orbit point's values; "
        "the orbit lies on the NHIM, so the slice has a NHIM point exactly there. `crossings`: distinct crossings "
        "refined by fates in the window; `distance`: the nearest one's distance from the orbit point (section "
        "coordinates); tolerances " + ", ".join(f"{s} {t:g}" for s, t in tolerances.items()) + ". Degenerate "
        "slices (`solved_momentum_vanishes`: the slice's energy boundary within the refinement's reach, "
        "`boundary_distance`; `tangent`: `transversality` to the NHIM from the orbit's monodromy below the minimum) "
        "are recorded, never checked as points.",
        "",
        "Statuses: " + ", ".join(f"{status} {count}" for status, count in sorted(counts.items())) + ".",
        "",
        "| " + " | ".join(ORBIT_COLUMNS) + " |",
        "|" + "---|" * len(ORBIT_COLUMNS),
    ]
    lines += ["| " + " | ".join(_format(row[c]) for c in ORBIT_COLUMNS) + " |" for row in rows]
    return "\n".join(lines) + "\n"


def _format(value) -> str:
    if isinstance(value, float):
        return f"{value:.10g}" if abs(value) >= 1e-3 or value == 0 else f"{value:.2e}"
    return str(value)


def _write_tables(rows: list[dict], columns: tuple[str, ...], csv_output: str | Path, markdown: str,
                  markdown_output: str | Path) -> None:
    write_text_atomic(markdown_output, markdown)
    text = io.StringIO()
    writer = csv.DictWriter(text, fieldnames=columns)
    writer.writeheader()
    writer.writerows(rows)
    write_text_atomic(csv_output, text.getvalue(), newline="")


def run_nhim_validation(
    *, studies: list[str | Path], csv_output: str | Path, markdown_output: str | Path, tolerance: float,
    residence_ratio: float, orbit_studies: list[str | Path] = (), orbits_csv_output: str | Path | None = None,
    orbits_markdown_output: str | Path | None = None,
) -> list[dict]:
    """Write the validation tables (CSV and Markdown) of the study files and of the orbit validation
    files, then fail if any slice fails.

    Raises
    ------
    NHIMValidationError
        Naming each failing slice and its distance or reason, after the tables are written.
    """
    check_writable(csv_output, markdown_output, orbits_csv_output, orbits_markdown_output)  # before any work: never lose a run to a bad path
    rows = [row for path in studies for row in validation_rows(path, tolerance, residence_ratio)]
    _write_tables(rows, TABLE_COLUMNS, csv_output, _markdown(rows, tolerance), markdown_output)
    failed = [row for row in rows if row["status"] != "ok"]
    for row in rows:
        log.info("%s / %s: distance %.3g, %s", row["study"], row["slice"], row["distance_refined"], row["status"])
    problems = [f"{r['study']}/{r['slice']}: {r['status'][6:]}" for r in failed]
    if orbits_csv_output is not None:
        orbit_rows = [row for path in orbit_studies for row in orbit_validation_rows(path)]
        attributes = [open_stage_file(p, stage=NHIM_ORBITS).attrs for p in orbit_studies]
        tolerances = {str(a["study"]): float(a["tolerance"]) for a in attributes}
        _write_tables(orbit_rows, ORBIT_COLUMNS, orbits_csv_output, _orbit_markdown(orbit_rows, tolerances),
                      orbits_markdown_output)
        for row in orbit_rows:
            if row["status"].startswith("fail:"):
                problems.append(f"{row['study']}/{row['family']}/E{row['E']:.6g}/phase {row['phase']:.4f}/{row['axes']} "
                                f"slice: {row['status'][5:]} ({row['reason']})")
        log.info("orbit validation: %d slices, %d failed", len(orbit_rows),
                 sum(r["status"].startswith("fail:") for r in orbit_rows))
    if problems:
        raise NHIMValidationError("NHIM validation failed for " + "; ".join(problems))
    return rows
