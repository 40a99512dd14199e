"""NHIM validation stage: the tables of the NHIM studies against their references, and the verdict.

It reads only the study files (:data:`ldpipe.contracts.NHIM`), so a change to the NHIM science
or the engine reruns the studies, and this stage only through their outputs.
"""

from __future__ import annotations

import csv
from pathlib import Path

from ..contracts import NHIM
from ..datafile import open_stage_file
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
    def fmt(value):
        if isinstance(value, float):
            return f"{value:.10g}" if abs(value) >= 1e-3 or value == 0 else f"{value:.2e}"
        return str(value)

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


def run_nhim_validation(
    *, studies: list[str | Path], csv_output: str | Path, markdown_output: str | Path, tolerance: float,
    residence_ratio: float,
) -> list[dict]:
    """Write the validation table (CSV and Markdown) of the study files, then fail if any slice fails.

    Raises
    ------
    NHIMValidationError
        Naming each failing slice and its distance, after the tables are written.
    """
    rows = [row for path in studies for row in validation_rows(path, tolerance, residence_ratio)]
    for path, text in ((Path(markdown_output), _markdown(rows, tolerance)),):
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)
    with open(csv_output, "w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=TABLE_COLUMNS)
        writer.writeheader()
        writer.writerows(rows)
    failed = [row for row in rows if row["status"] != "ok"]
    for row in rows:
        log.info("%s / %s: distance %.3g, %s", row["study"], row["slice"], row["distance_refined"], row["status"])
    if failed:
        raise NHIMValidationError(
            "NHIM validation failed for " + "; ".join(f"{r['study']}/{r['slice']}: {r['status'][6:]}" for r in failed)
        )
    return rows
