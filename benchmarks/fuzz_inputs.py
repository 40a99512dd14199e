"""Fuzz ldpipe's inputs and count what happens: every example must end valid, or refused with a
message naming what was wrong; anything else (a traceback, a NaN in a result, a file written for
bad input) is a failure, printed with the example that found it.

Four families, ``--examples`` of each, drawn from ``--seed``:

- ``config``: config.yaml with config.quick.yaml over it, one key mutated (every key and every
  key the schema allows, ``ldpipe.testing.fuzz``), validated;
- ``api``: the keywords of ``ldpipe.system``, ``ldpipe.section`` and ``ldpipe.ld_map`` (a 3 x 3
  map of the Hénon–Heiles formula system) mutated; a valid map is computed if small (at most
  5 x 5 points, tau <= 50) and its data checked finite;
- ``cli``: the arguments of ``ldpipe ld --system ... --axis ...`` mutated, run in-process: exit
  0 with a file, or an error on stderr with no traceback and no file (nor temporary) left;
- ``files``: the double gyre's netCDF file corrupted one way at a time (``FILE_CASES``), read as
  a ``velocity_data`` system and, if valid, its 4 x 3 map computed and checked finite.

    python benchmarks/fuzz_inputs.py                      # 30 of each, a minute
    python benchmarks/fuzz_inputs.py --examples 10000     # the reliability page's run

The tests (tests/fuzz/) draw their examples through the same checks, with hypothesis.
"""

from __future__ import annotations

import argparse
import collections
import contextlib
import io
import math
import platform
import sys
import tempfile
import time
import traceback
from pathlib import Path

import numpy as np
import yaml

ROOT = Path(__file__).resolve().parents[1]

#: The formula system the API's and the command line's examples are of.
HH = {"formula": "(x**2 + y**2)/2 + x**2*y - y**3/3", "coordinates": ["x", "y"]}
SYSTEM_KWARGS = {"name": "henon_heiles", **HH, "equilibria": {"box": {"x": [-2.0, 2.0], "y": [-2.0, 2.0]},
                                                               "seeds_per_axis": 5}}
SECTION_KWARGS = {"y": [-0.3, 0.5, 3], "py": [-0.3, 0.3, 3], "fixed": {"px": 0.0}, "solve": "x", "root": "largest"}
MAP_KWARGS = {"energy": 0.125, "tau": 2.0, "p": 0.5, "time": "fixed",
              "integrator": {"scheme": "dop853", "rtol": 1e-8, "atol": 1e-8}}
#: A valid map is integrated only this small: the fuzzer looks for faults, not for long runs.
ENGINE_POINTS, ENGINE_TAU = 25, 50.0

#: A 4 x 3 map of a velocity-data file's double gyre (``ldpipe.testing.fuzz.GRID``).
GYRE_SECTION = {"axes": [{"name": "x", "range": [0.2, 1.8], "points": 4},
                         {"name": "y", "range": [0.2, 0.8], "points": 3}], "fixed": {}}

#: ``ldpipe ld`` of the Hénon–Heiles slice (the system declared in a configuration file).
CLI_OPTIONS = {"--system": "henon_heiles", "--axis": ["y=-0.3:0.5:3", "py=-0.3:0.3:3"], "--fixed": ["px=0.0"],
               "--solve": "x", "--root": "largest", "--energy": "0.125", "--tau": "2", "--p": "0.5",
               "--rtol": "1e-8", "--atol": "1e-8", "--quiet": None, "--threads": "1"}
#: What a command-line argument is replaced by.
CLI_VALUES = ["", "nan", "inf", "-inf", "-1", "0", "1e308", "abc", "=", ":", "1:2", "x=1:2", "3:1:3", "y=0.8:-0.45:3",
              "y=0:0:3", "y=1:2:0", "y=1:2:2.5", "q=1:2:3", "px=saddle", "largest", "nearest:0.5", "nearest:nan",
              "variable", "rk4", "arclength", "--", "-o"]


def base_config() -> dict:
    from ldpipe.testing.fuzz import merged

    return merged(yaml.safe_load((ROOT / "config.yaml").read_text()),
                  yaml.safe_load((ROOT / "config.quick.yaml").read_text()))


# Configuration ----------------------------------------------------------------------------------

class ConfigFamily:
    def __init__(self):
        from ldpipe.config import validate_config
        from ldpipe.config.loading import load_schema
        from ldpipe.testing import fuzz

        self.validate = validate_config
        self.base = validate_config(base_config())
        self.sites = fuzz.config_sites(self.base, load_schema())
        self.mutations = list(fuzz.MUTATIONS)

    def draw(self, rng: np.random.Generator):
        return self.sites[rng.integers(len(self.sites))], self.mutations[rng.integers(len(self.mutations))]

    def check(self, case) -> str:
        from ldpipe.testing.fuzz import check_config_case

        return check_config_case(self.base, *case, self.validate)


# The Python API ---------------------------------------------------------------------------------

def _kwarg_sites(kwargs: dict) -> list[tuple]:
    from ldpipe.testing.fuzz import config_sites

    return [*config_sites(kwargs, {}), ("fuzz_unknown_argument",)]


class ApiFamily:
    """Cases ``(function, path, mutation)``: the keywords of ``ldpipe.system``, ``ldpipe.section``
    or ``ldpipe.ld_map`` with one mutated."""

    BASES = {"system": SYSTEM_KWARGS, "section": SECTION_KWARGS, "ld_map": MAP_KWARGS}

    def __init__(self):
        import ldpipe
        from ldpipe.testing import fuzz

        self.ldpipe = ldpipe
        self.mutations = list(fuzz.MUTATIONS)
        self.sites = {function: _kwarg_sites(base) for function, base in self.BASES.items()}
        self.system = ldpipe.system(**SYSTEM_KWARGS)
        self.equilibria = ldpipe.equilibria(self.system)
        self.integrated = 0

    def draw(self, rng: np.random.Generator):
        function = list(self.BASES)[rng.integers(len(self.BASES))]
        sites = self.sites[function]
        return function, sites[rng.integers(len(sites))], self.mutations[rng.integers(len(self.mutations))]

    def check(self, case) -> str:
        from ldpipe.testing import fuzz

        function, path, mutation = case
        what = f"ldpipe.{function} {fuzz.dotted(path)} <- {mutation}"
        kwargs = {name: fuzz.plain(base) for name, base in self.BASES.items()}
        kwargs[function] = fuzz.mutate(kwargs[function], path, mutation)
        try:
            if function == "system":
                self.ldpipe.system(**kwargs["system"])
                return "valid"
            section = self.ldpipe.section(**kwargs["section"])
            if not self._small(section, kwargs["ld_map"]):
                self._validate(section, kwargs["ld_map"])
                return "valid"
            result = self.ldpipe.ld_map(self.system, equilibria=self.equilibria, section=section, threads=1,
                                        **kwargs["ld_map"])
            self.integrated += 1
        except Exception as error:
            # the function and the argument: its top-level keyword (a section's axis or option,
            # given to ld_map as 'section')
            names = [f"ldpipe.{function}" if function != "section" else "ldpipe."]
            return fuzz.check_refusal(error, what, *names) if self._names(error, path, function) else \
                _fail(what, f"the message does not name the argument {path[0]!r}: {error}")
        fuzz.finite_dataset(result, what)
        return "valid"

    @staticmethod
    def _names(error, path, function) -> bool:
        message = str(error)
        if function == "section" and "argument 'section" in message:
            return True
        return str(path[0]) in message

    def _small(self, section, kwargs) -> bool:
        try:
            points = math.prod(int(axis["points"]) for axis in section["axes"])
            return points <= ENGINE_POINTS and float(kwargs.get("tau", 0)) <= ENGINE_TAU
        except (TypeError, ValueError, KeyError, OverflowError):
            return True  # not a grid or not a number: the call refuses it before the engine

    def _validate(self, section, kwargs) -> None:
        """What ``ld_map`` checks before it integrates (its configuration entry validated)."""
        from ldpipe.api.arguments import arguments_of, energy_shorthand, entry_parameters, system_config

        entry = {"system": self.system.name, "section": section, **energy_shorthand(kwargs)}
        with arguments_of("ld_map", "ld_maps.map"):
            entry_parameters(entry, system_config(self.system), "ld_maps", "map", "ld")


def _fail(what: str, why: str):
    from ldpipe.testing.fuzz import FuzzFailure

    raise FuzzFailure(f"{what}: {why}")


# The command line -------------------------------------------------------------------------------

class CliFamily:
    """Cases ``(option, index, value)``: one of ``ldpipe ld``'s arguments replaced by a value of
    :data:`CLI_VALUES` (``index`` picks one of a repeated option's), removed (``value`` None), or an
    option given twice."""

    def __init__(self, workdir: Path):
        self.workdir = Path(workdir)
        self.config = self.workdir / "hh.yaml"
        self.config.write_text(yaml.safe_dump({"systems": {"henon_heiles": {
            **HH, "equilibria": SYSTEM_KWARGS["equilibria"]}}}))
        self.options = list(CLI_OPTIONS)
        self.count = 0
        from ldpipe.cli.main import main

        self.equilibria = self.workdir / "hh_equilibria.nc"
        with contextlib.redirect_stderr(io.StringIO()):
            assert main(["equilibria", "--config", str(self.config), "--system", "henon_heiles",
                         "-o", str(self.equilibria)]) == 0

    def draw(self, rng: np.random.Generator):
        option = self.options[rng.integers(len(self.options))]
        choice = rng.integers(len(CLI_VALUES) + 2)
        value = CLI_VALUES[choice] if choice < len(CLI_VALUES) else (None if choice == len(CLI_VALUES) else "twice")
        return option, int(rng.integers(2)), value

    def argv(self, case, output: Path) -> list[str]:
        option, index, value = case
        argv = ["ld", "--config", str(self.config), "--equilibria", str(self.equilibria)]
        for key, given in CLI_OPTIONS.items():
            values = list(given) if isinstance(given, list) else [given]
            if key == option:
                if value is None:
                    continue
                if value == "twice":
                    values = values * 2
                elif given is None:  # a flag, given a value
                    values = [None, value]
                else:
                    values[index % len(values)] = value
            for item in values:
                if item is None:
                    argv.append(key)
                elif item.startswith("-"):  # argparse reads "--tau -1" as two options
                    argv.append(f"{key}={item}")
                else:
                    argv += [key, item]
        return argv + ["-o", str(output)]

    def check(self, case) -> str:
        from ldpipe.cli.main import main
        from ldpipe.testing import fuzz

        self.count += 1
        folder = self.workdir / f"run{self.count}"
        folder.mkdir()
        output = folder / "out.nc"
        argv = self.argv(case, output)
        what = "ldpipe " + " ".join(argv)
        stderr, stdout = io.StringIO(), io.StringIO()
        parsed = True
        try:
            with contextlib.redirect_stderr(stderr), contextlib.redirect_stdout(stdout):
                code = main(argv)
        except SystemExit as exit:  # argparse's refusals: its usage line, then the error's
            code, parsed = exit.code, False
        except Exception as error:
            raise fuzz.FuzzFailure(f"{what}: {type(error).__name__}: {error}") from error
        message = stderr.getvalue()
        left = sorted(p.name for p in folder.iterdir())
        if "Traceback" in message:
            _fail(what, f"a traceback on stderr: {message}")
        if code == 0:
            if left != ["out.nc"]:
                _fail(what, f"exit 0, but the folder holds {left}")
            import xarray as xr

            with xr.open_dataset(output) as result:
                fuzz.finite_dataset(result.load(), what)
            return "valid"
        if left:
            _fail(what, f"exit {code}, but it wrote {left}")
        lines = [line for line in message.splitlines() if line.strip()]
        if not lines or not lines[-1].startswith("ldpipe ld: error: " if parsed else ("ldpipe ld: error: ",
                                                                                      "ldpipe: error: ")):
            _fail(what, f"exit {code} without a one-line error message: {message!r}")
        return "refused"


# Velocity-data files ----------------------------------------------------------------------------

class FilesFamily:
    def __init__(self, workdir: Path):
        import ldpipe
        from ldpipe.testing import fuzz

        self.ldpipe, self.fuzz = ldpipe, fuzz
        self.workdir = Path(workdir)
        self.count = 0

    def draw(self, rng: np.random.Generator):
        cases = self.fuzz.FILE_CASES
        return cases[rng.integers(len(cases))], float(rng.random())

    def check(self, case) -> str:
        corruption, fraction = case
        self.count += 1
        folder = self.workdir / f"file{self.count}"
        path, entry = self.fuzz.write_velocity_case(folder, corruption, fraction)
        what = f"file {corruption} ({fraction:.3f})"
        try:
            system = self.ldpipe.system(name="data", velocity_data=entry)
            result = self.ldpipe.ld_map(system, section=GYRE_SECTION, tau=3.0, t0=4.0, threads=1)
        except Exception as error:
            return self.fuzz.check_refusal(error, what, *self.fuzz.file_case_names(path, corruption))
        self.fuzz.finite_dataset(result, what)
        return "valid"


def run(family, examples: int, seed: int) -> tuple[collections.Counter, list[str]]:
    from ldpipe.testing.fuzz import FuzzFailure

    rng = np.random.default_rng(seed)
    counts, failures = collections.Counter(), []
    for _ in range(examples):
        case = family.draw(rng)
        counts["tried"] += 1
        try:
            counts[family.check(case)] += 1
        except FuzzFailure as failure:
            counts["failures"] += 1
            cause = failure.__cause__
            failures.append(f"{failure}" + (f"\n{''.join(traceback.format_exception(cause))}" if cause else ""))
    return counts, failures


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--examples", type=int, default=30, help="examples of each family (default 30)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the draws (default 0)")
    parser.add_argument("--families", nargs="+", default=["config", "api", "cli", "files"],
                        choices=["config", "api", "cli", "files"])
    args = parser.parse_args(argv)
    print(f"{platform.node()}, {platform.processor() or platform.machine()}, Python {platform.python_version()}, "
          f"{args.examples} examples of each family, seed {args.seed}")
    total = 0
    with tempfile.TemporaryDirectory() as scratch:
        makers = {"config": ConfigFamily, "api": ApiFamily, "cli": lambda: CliFamily(Path(scratch)),
                  "files": lambda: FilesFamily(Path(scratch))}
        for name in args.families:
            start = time.perf_counter()
            family = makers[name]()
            counts, failures = run(family, args.examples, args.seed)
            seconds = time.perf_counter() - start
            extra = f" ({family.integrated} maps computed)" if name == "api" else ""
            print(f"{name:7s} tried {counts['tried']}, valid {counts['valid']}, refused with a message naming the "
                  f"input {counts['refused']}, failures {counts['failures']}{extra} ({seconds:.0f} s)")
            for failure in failures[:20]:
                print("  FAILURE", failure.replace("\n", "\n    "))
            total += counts["failures"]
    return 1 if total else 0


if __name__ == "__main__":
    sys.exit(main())
