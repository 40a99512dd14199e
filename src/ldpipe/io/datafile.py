"""netCDF conventions shared by every stage: attributes, provenance, compression, atomic writes.

Every stage file is an xarray Dataset written with the netCDF4 engine and carries
CF-style global attributes (``Conventions``, ``title``, ``history``,
``source``), the stage's parameters as JSON, the ldpipe version and the git
commit when known. Reading checks that a file is a readable netCDF file written
by the expected stage, holding the variables the stage's contract
(:mod:`ldpipe.io.contracts`) names, and names the file in every error.
"""

from __future__ import annotations

import datetime as _dt
import functools
import json
import os
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

import numpy as np
import xarray as xr

from .._version import __version__
from ..errors import StageFileError
from ..logs import get_logger
from .atomic import check_writable, write_or_keep
from .contracts import CONTRACTS, StageFile

log = get_logger(__name__)

ENGINE = "netcdf4"
CONVENTIONS = "CF-1.10"
STAGE_ATTRIBUTE = "ldpipe_stage"
# Lossless, for every numeric variable of a stage file that stays; level 1 writes 20 % faster than
# level 4 for 3 % more bytes (benchmarks/stage_compression.md). An intermediate file (a map's tile,
# read once and deleted) is written uncompressed: five times cheaper to write, twice to read.
COMPRESSION = {"zlib": True, "complevel": 1, "shuffle": True}
# Global attributes every write sets itself; a stage's own attributes are the others.
MANAGED_ATTRIBUTES = (
    "Conventions", "title", "history", "source", STAGE_ATTRIBUTE, "ldpipe_version", "git_commit", "parameters",
)


@functools.cache
def git_commit() -> str:
    """The commit of the source tree ldpipe runs from, with ``-dirty`` if it has edits; '' if unknown.
    Read once per process: the code a process runs is what it imported, and two ``git`` calls cost
    tens of milliseconds, which a map written in many blocks would pay for each."""
    source = Path(__file__).resolve().parent
    try:
        commit = subprocess.run(
            ["git", "-C", str(source), "rev-parse", "HEAD"],
            capture_output=True, text=True, timeout=5, check=True,
        ).stdout.strip()
        dirty = subprocess.run(
            ["git", "-C", str(source), "status", "--porcelain", "--untracked-files=no", "--", "."],
            capture_output=True, text=True, timeout=5, check=True,
        ).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return ""
    return commit + ("-dirty" if dirty else "")


def check_finite(dataset: xr.Dataset, where) -> None:
    """A ValueError naming ``where`` and the variable if any floating-point variable holds NaN or inf."""
    for name, variable in dataset.variables.items():
        if np.issubdtype(variable.dtype, np.floating) and not np.all(np.isfinite(variable.values)):
            raise ValueError(f"{where}: variable {name!r} holds NaN or inf; refusing to write it")


def _json_default(value):
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, Path):
        return str(value)
    raise TypeError(f"cannot record {type(value).__name__} in the parameters attribute")


def _as_read_back(value):
    """An attribute as netCDF reads it back: a one-element numeric vector comes back as its element
    (a netCDF attribute is always a vector, and a vector of one is read as a scalar)."""
    if isinstance(value, (np.ndarray, list, tuple)) and not isinstance(value, str):
        array = np.asarray(value)
        if array.size == 1 and array.ndim > 0 and array.dtype.kind in "fiu":
            return array.reshape(-1)[0]
    return value


def stage_dataset(dataset: xr.Dataset, *, stage: str | StageFile, title: str, parameters: dict) -> xr.Dataset:
    """``dataset`` as the file of ``stage`` (its contract, or a bare stage name) holds it and
    :func:`open_stage_file` reads it back: ldpipe's global attributes (the parameters as JSON, the
    version, the commit), flags kept as booleans with their CF flag attributes, text as fixed-width
    strings, one-element numeric attributes as scalars. Every library function of a stage product
    returns its Dataset through this, so the Python API hands back, in memory, what the pipeline
    writes. Floating-point data must be finite.
    """
    stage = stage.stage if isinstance(stage, StageFile) else stage
    check_finite(dataset, f"the {stage!r} stage's data")
    dataset = dataset.copy()
    now = _dt.datetime.now(_dt.timezone.utc).replace(microsecond=0).isoformat()
    command = " ".join([Path(sys.argv[0]).name, *sys.argv[1:]]) if sys.argv else "python"
    dataset.attrs.update(
        {
            "Conventions": CONVENTIONS,
            "title": title,
            "history": f"{now} written by ldpipe {__version__} ({command})",
            "source": f"ldpipe {__version__}",
            STAGE_ATTRIBUTE: stage,
            "ldpipe_version": __version__,
            "git_commit": git_commit() or "unknown",
            "parameters": json.dumps(parameters, sort_keys=True, default=_json_default),
        }
    )
    dataset.attrs.update({key: _as_read_back(value) for key, value in dataset.attrs.items()})
    for variable in dataset.variables.values():
        variable.attrs.update({key: _as_read_back(value) for key, value in variable.attrs.items()})
    for variable in dataset.data_vars.values():
        if variable.dtype.kind == "b":  # netCDF has no bool type: the file keeps 0/1 bytes and says what they mean
            variable.attrs.setdefault("flag_values", np.array([0, 1], dtype=np.int8))
            variable.attrs.setdefault("flag_meanings", "false true")
    text = {name: variable.astype(str) for name, variable in dataset.variables.items()
            if variable.dtype.kind == "O" and all(isinstance(v, str) for v in variable.values.flat)}
    # as xarray reads a file's strings back
    dataset = dataset.assign_coords({name: v for name, v in text.items() if name in dataset.coords})
    return dataset.assign({name: v for name, v in text.items() if name not in dataset.coords})


def write_stage_file(dataset: xr.Dataset, path: str | os.PathLike, *, stage: str | StageFile | None = None,
                     title: str | None = None, parameters: dict | None = None) -> Path:
    """Write a stage file to ``path``, atomically: ``dataset`` as a stage product's function
    returned it (:func:`stage_dataset`), or, given ``stage``, ``title`` and ``parameters``, made
    one here.

    The file is written to a temporary name in the same folder and renamed into
    place only once complete (:func:`ldpipe.io.atomic.atomic_path`), so a job killed mid-write
    never leaves a file under the final name. Numeric variables are compressed
    (``COMPRESSION``), except in a contract's intermediate files.

    Raises
    ------
    OutputError
        naming ``path`` if the file cannot be written (a full disk, a folder that went away);
        the file already at ``path`` is left as it was, and the result is kept in the system's
        temporary folder if it can be, named in the message.
    """
    path = Path(path)
    if stage is not None:
        dataset = stage_dataset(dataset, stage=stage, title=title, parameters=parameters)
    elif STAGE_ATTRIBUTE not in dataset.attrs:
        raise ValueError(f"{path}: the dataset is not a stage product (no {STAGE_ATTRIBUTE!r} attribute); "
                         "give stage, title and parameters")
    check_finite(dataset, path)
    # the contract given, else the one registered for the stage the dataset names
    contract = stage if isinstance(stage, StageFile) else CONTRACTS.get(dataset.attrs[STAGE_ATTRIBUTE])
    compression = {} if contract is not None and contract.intermediate else COMPRESSION
    dataset = dataset.copy()
    encoding = {}
    for name, variable in dataset.data_vars.items():
        if variable.dtype.kind in "fiub":
            encoding[name] = dict(compression)  # replaces what the variable carries from a file it was read from
            if variable.dtype.kind == "b":
                dataset[name] = variable.astype(np.int8)

    def write(temporary: Path) -> None:
        try:
            dataset.to_netcdf(temporary, engine=ENGINE, format="NETCDF4", encoding=encoding)
        except RuntimeError as error:  # the netCDF library's own failures, a full disk among them
            raise OSError(f"the netCDF library failed: {error}; is the disk full, or a file-size limit set?") from error

    write_or_keep(path, write)
    return path


def write_product(output: str | os.PathLike, make: Callable[[], xr.Dataset],
                  describe: Callable[[xr.Dataset], str] | None = None) -> Path:
    """What every stage does with its product: ``output`` checked writable before any work
    (:func:`ldpipe.io.atomic.check_writable`, so a bad path never costs a run), the product made
    (``make()``, the core's function), written (:func:`write_stage_file`) and logged, with what
    ``describe(dataset)`` says of it."""
    check_writable(output)
    dataset = make()
    path = write_stage_file(dataset, output)
    log.info("wrote %s%s", path, f" ({describe(dataset)})" if describe else "")
    return path


def open_stage_file(
    path: str | os.PathLike | xr.Dataset, *, stage: str | StageFile, variables: tuple[str, ...] | None = None,
    only: bool = False,
) -> xr.Dataset:
    """Load a stage file into memory, checking it is what ``stage`` wrote.

    Parameters
    ----------
    path : path or xarray.Dataset
        The file; or a stage file already in memory (as :func:`open_stage_file` or the Python API
        returned it), checked the same way and returned as it is.
    stage : StageFile or str
        The stage's contract (:mod:`ldpipe.io.contracts`), or a bare stage name.
    variables : tuple of str, optional
        The variables the reader needs, which the file must hold: by default every variable of
        the contract (none for a bare name). With a contract, each must be one it names.
    only : bool
        Load only ``variables`` (and the coordinates), not every variable of the file: for a
        reader of a few fields of a large map, which would otherwise decompress them all.

    Raises
    ------
    StageFileError
        naming the file and what was expected, if it is missing, not a readable
        netCDF file, written by another stage or program, or lacks ``variables``.
    ValueError
        if ``variables`` names one the stage's contract does not.
    """
    if isinstance(stage, StageFile):
        if variables is None:
            variables = stage.variables
        unnamed = [name for name in variables if name not in stage.variables]
        if unnamed:
            raise ValueError(f"variables {unnamed} are not in the {stage.stage!r} stage's contract "
                             "(ldpipe.io.contracts)")
        stage = stage.stage
    variables = variables or ()
    if isinstance(path, xr.Dataset):
        _check_stage(path, "the dataset given", stage, variables)
        return path
    path = Path(path)
    if not path.is_file():
        raise StageFileError(f"{path}: no such file; expected the output of the {stage!r} stage")
    try:
        with xr.open_dataset(path, engine=ENGINE) as opened:
            _check_stage(opened, path, stage, variables)
            dataset = (opened[list(variables)] if only else opened).load()
    except StageFileError:
        raise
    except Exception as error:  # netCDF4/HDF5 raise OSError, RuntimeError, ValueError...
        raise StageFileError(
            f"{path}: not a readable netCDF file ({type(error).__name__}: {error}); "
            f"expected the output of the {stage!r} stage; delete it and rerun that stage"
        ) from None
    for name, variable in dataset.data_vars.items():
        if variable.attrs.get("flag_meanings") == "false true":
            dataset[name] = variable.astype(bool)
    return dataset


def _check_stage(dataset: xr.Dataset, where, stage: str, variables: tuple[str, ...]) -> None:
    """A StageFileError naming ``where`` unless ``dataset`` was written by ``stage`` and holds ``variables``."""
    found = dataset.attrs.get(STAGE_ATTRIBUTE)
    if found is None:
        raise StageFileError(
            f"{where}: not written by ldpipe (no {STAGE_ATTRIBUTE!r} attribute); "
            f"expected the output of the {stage!r} stage"
        )
    if found != stage:
        raise StageFileError(f"{where}: written by the {found!r} stage; expected the {stage!r} stage")
    missing = [name for name in variables if name not in dataset.variables]
    if missing:
        raise StageFileError(f"{where}: lacks variables {missing} that the {stage!r} stage writes")


def input_name(source: str | os.PathLike | xr.Dataset) -> str:
    """How a stage's file records one of its inputs: the input file's path, or the title of a
    stage file given in memory (by the Python API), which has no path."""
    if isinstance(source, xr.Dataset):
        return f"(in memory) {source.attrs.get('title', 'untitled')}"
    return str(source)


def stage_parameters(dataset: xr.Dataset) -> dict:
    """The parameters a stage file was computed with."""
    return json.loads(dataset.attrs["parameters"])
