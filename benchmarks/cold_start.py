"""Cold start: the README's two commands on an empty cache, and what they compile.

Runs, with a private, empty engine cache (``LDPIPE_CACHE_DIR`` and ``NUMBA_CACHE_DIR`` in a
temporary folder, so nothing already compiled on this machine is reused):

1. the workflow, ``snakemake --cores N [--configfile FILE ...]``, on a copy of the workflow's
   files (the README's main command without ``--configfile``; ``results/`` of the clone is
   untouched);
2. the tests, ``pytest [PATHS] [-m EXPR] [-n WORKERS]`` from the repository (the README's test
   command without paths, on pytest-xdist's workers as pyproject's addopts say unless ``-n`` is
   given), after the workflow, so with the cache it left (``--tests-cold`` empties it first).

``LDPIPE_COMPILE_LOG`` (:mod:`ldpipe.jitcache`) makes every process append one line per engine
or kernel module it loads and per function numba compiles (a cache miss), with the compile's
wall and CPU seconds and the Snakemake rule or pytest test that asked, and one per wait for
another process's compile of a module (its lock). The report gives, per Snakemake job (its
benchmark file: wall ``s`` and ``cpu_time``) and per test file (pytest's JUnit times), the
modules compiled and their compile time, the waits and their seconds, and the functions that
more than one process compiled (two workers or jobs that needed one before either had cached it,
which the lock prevents unless the file system refuses it); the run's wall and CPU seconds
(``getrusage`` of the children) and the load average before and after, since a shared machine
slows every compile. ``--rerun`` runs the workflow a second time, forced, on the warm cache.

The count of modules compiled does not depend on the machine or its load: it is the measure to
compare changes by. Times do.

    python benchmarks/cold_start.py                                   # the README's two commands
    python benchmarks/cold_start.py --configfile config.quick.yaml --no-tests
    python benchmarks/cold_start.py --no-workflow --tests tests/engine -m "not slow"
"""

from __future__ import annotations

import argparse
import collections
import csv
import json
import os
import platform
import resource
import shutil
import subprocess
import sys
import tempfile
import time
import xml.etree.ElementTree as ElementTree
from pathlib import Path

from ldpipe.core.accuracy import cpu_model

ROOT = Path(__file__).resolve().parents[1]
BIN = Path(sys.executable).parent
WORKFLOW_FILES = ("Snakefile", "config.yaml", "config.quick.yaml")
WORKFLOW_FOLDERS = ("workflow", "profiles")


def load_average() -> str:
    try:
        return ", ".join(f"{v:.2f}" for v in os.getloadavg())
    except OSError:
        return "unknown"


def timed(command: list[str], cwd: Path, env: dict, output: Path) -> dict:
    """Run ``command``; its wall and CPU seconds (user + system of every child process)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    load = load_average()
    start = time.perf_counter()
    with output.open("w") as out:
        completed = subprocess.run(command, cwd=cwd, env=env, stdout=out, stderr=subprocess.STDOUT)
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return {"command": " ".join(command), "returncode": completed.returncode, "wall_s": wall, "cpu_s": cpu,
            "load_before": load, "load_after": load_average(), "output": str(output)}


def read_log(path: Path) -> list[dict]:
    if not path.is_file():
        return []
    return [json.loads(line) for line in path.read_text().splitlines() if line.strip()]


def new_entry() -> dict:
    return {"modules": set(), "loaded": set(), "wall_s": 0.0, "cpu_s": 0.0, "waits": 0, "waited_s": 0.0}


def compiles_by(records: list[dict], key) -> dict:
    """Per ``key(record)``: modules loaded and compiled (sets), compile wall and CPU seconds, the
    waits for another process's compile and their wall seconds."""
    found = collections.defaultdict(new_entry)
    for record in records:
        if record["event"] == "load":
            found[key(record)]["loaded"].add(record["module"])
        if record["event"] == "compile":
            entry = found[key(record)]
            entry["modules"].add(record["module"])
            entry["wall_s"] += record["wall_s"]
            entry["cpu_s"] += record["cpu_s"]
        if record["event"] == "wait":
            entry = found[key(record)]
            entry["waits"] += 1
            entry["waited_s"] += record["wall_s"]
    return found


ENGINE_PREFIXES = ("engine_", "flow_", "vfield_engine_")


def is_engine(module: str) -> bool:
    """An engine module (the LD or flow driver of a system and scheme), not a system's small kernels."""
    return short(module).startswith(ENGINE_PREFIXES)


def counts(loaded: set, compiled: set) -> str:
    engines = lambda modules: sum(map(is_engine, modules))  # noqa: E731
    return (f"{len(loaded)} generated modules loaded ({engines(loaded)} engine modules), {len(compiled)} compiled "
            f"({engines(compiled)} engine modules)")


def short(module: str) -> str:
    """A module's name without the common prefix (system, scheme, lanes and the hash remain)."""
    return module.removeprefix("ldpipe_generated_")


def benchmark_row(path: Path) -> dict:
    """Snakemake's benchmark file: wall seconds ``s`` and ``cpu_time`` of the job's last run."""
    with path.open() as handle:
        rows = list(csv.DictReader(handle, delimiter="\t"))
    row = rows[-1] if rows else {}
    number = lambda key: float(row[key]) if row.get(key) not in (None, "", "NA", "-") else float("nan")  # noqa: E731
    return {"wall_s": number("s"), "cpu_s": number("cpu_time")}


def job_of(record: dict) -> str:
    """A compile's job, named by its log file (relative to results/logs), else its rule."""
    logs = record.get("log") or []
    if logs:
        return str(Path(logs[0])).split("logs/", 1)[-1].removesuffix(".log")
    return record.get("rule") or f"(pid {record['pid']}, no Snakemake job)"


def workflow_section(folder: Path, run: dict, records: list[dict], title: str) -> list[str]:
    jobs = compiles_by(records, job_of)
    benchmarks = {}
    results = folder / "results" / "benchmarks"
    for path in sorted(results.rglob("*.tsv")) if results.is_dir() else []:
        benchmarks[str(path.relative_to(results)).removesuffix(".tsv")] = benchmark_row(path)
    modules = set().union(*(j["modules"] for j in jobs.values())) if jobs else set()
    loaded = set().union(*(j["loaded"] for j in jobs.values())) if jobs else set()
    lines = [f"## {title}", "", f"`{run['command']}`: exit {run['returncode']}, wall {run['wall_s']:.0f} s, "
             f"CPU {run['cpu_s']:.0f} s ({run['cpu_s'] / max(run['wall_s'], 1e-9):.2f} cores busy on average); "
             f"load average before {run['load_before']}, after {run['load_after']}; "
             f"{counts(loaded, modules)}, {sum(j['cpu_s'] for j in jobs.values()):.0f} CPU s of compiling; "
             f"{waits(records)}; {repeated_compiles(records)}; {jobs_and_rest(run, benchmarks)}.", "",
             "| job | wall s | CPU s | modules loaded | compiled | compile wall s | compile CPU s | waits | waited s |",
             "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |"]
    names = sorted(set(benchmarks) | set(jobs), key=lambda n: -benchmarks.get(n, {"wall_s": 0})["wall_s"])
    for name in names:
        bench = benchmarks.get(name, {"wall_s": float("nan"), "cpu_s": float("nan")})
        job = jobs.get(name, new_entry())
        lines.append(f"| {name} | {bench['wall_s']:.1f} | {bench['cpu_s']:.1f} | {len(job['loaded'])} | {len(job['modules'])} "
                     f"| {job['wall_s']:.1f} | {job['cpu_s']:.1f} | {job['waits']} | {job['waited_s']:.1f} |")
    lines += ["", *module_table(records, test_file), ""]
    return lines


def waits(records: list[dict]) -> str:
    """The waits for another process's compile of a module: how many, of how many modules, their wall seconds."""
    found = [record for record in records if record["event"] == "wait"]
    modules = {record["module"] for record in found}
    return (f"{len(found)} waits for another process's compile ({len(modules)} modules), "
            f"{sum(record['wall_s'] for record in found):.0f} s waited")


def jobs_and_rest(run: dict, benchmarks: dict) -> str:
    """The jobs' CPU seconds by their benchmark files, and the rest of the run's: Snakemake's main
    process, and what the benchmarks miss (their last sample comes up to 0.5 s before a short
    job's end, 30 s before a long one's, and never sees the interpreter's exit)."""
    jobs = sum(b["cpu_s"] for b in benchmarks.values() if b["cpu_s"] == b["cpu_s"])
    return f"{len(benchmarks)} jobs' benchmarks {jobs:.0f} CPU s, the rest {run['cpu_s'] - jobs:.0f}"


def repeated_compiles(records: list[dict]) -> str:
    """The functions compiled by more than one process, and the CPU seconds of all but one compile of each."""
    by_function = collections.defaultdict(list)
    for record in records:
        if record["event"] == "compile":
            by_function[record["module"], record["function"]].append(record)
    repeated = {key: found for key, found in by_function.items() if len({r["pid"] for r in found}) > 1}
    extra = sum(sum(r["cpu_s"] for r in found) - max(r["cpu_s"] for r in found) for found in repeated.values())
    modules = {module for module, _ in repeated}
    return (f"{len(repeated)} functions ({len(modules)} modules) compiled by more than one process, "
            f"{extra:.0f} CPU s of compiling repeated")


def module_table(records: list[dict], who) -> list[str]:
    """Every module loaded: its compile time here (0 if numba's cache held it), the seconds others
    waited for its compile, and who used it (``who(record)``)."""
    compiled = compiles_by(records, lambda r: r["module"])
    users = collections.defaultdict(set)
    for record in records:
        if record["event"] == "load":
            users[record["module"]].add(who(record))
    lines = ["| module | compile wall s | compile CPU s | waited s | loaded by |", "| --- | ---: | ---: | ---: | --- |"]
    order = sorted(users, key=lambda m: (-compiled[m]["cpu_s"] if m in compiled else 0.0, m))
    for module in order:
        entry = compiled.get(module, new_entry())
        names = sorted(users[module])
        shown = ", ".join(names[:4]) + (f" and {len(names) - 4} more" if len(names) > 4 else "")
        lines.append(f"| {short(module)} | {entry['wall_s']:.1f} | {entry['cpu_s']:.1f} | {entry['waited_s']:.1f} "
                     f"| {shown} |")
    return lines


def test_file(record: dict) -> str:
    return record.get("test", "(outside a test)").split("::", 1)[0]


def junit_times(path: Path) -> dict[str, tuple[float, int]]:
    """Per test file: the seconds pytest's JUnit report gives its tests, and how many ran."""
    found = collections.defaultdict(lambda: [0.0, 0])
    if not path.is_file():
        return {}
    for case in ElementTree.parse(path).iter("testcase"):
        module = case.get("classname", "").split("::")[0]
        name = module.replace(".", "/") + ".py" if module else "?"
        found[name][0] += float(case.get("time", 0.0))
        found[name][1] += 1
    return {name: (t, n) for name, (t, n) in found.items()}


def test_files(paths: list[str]) -> list[str]:
    """The test files under ``paths`` (files or folders, relative to the repository; default: tests)."""
    found = []
    for path in paths or ["tests"]:
        path = ROOT / path
        found += sorted(path.rglob("test_*.py")) if path.is_dir() else [path]
    return [str(f.relative_to(ROOT)) for f in found]


def tests_section(run: dict, records: list[dict], junits: list[Path]) -> list[str]:
    files = compiles_by(records, test_file)
    times = {}
    for junit in junits:
        times.update(junit_times(junit))
    modules = set().union(*(f["modules"] for f in files.values())) if files else set()
    loaded = set().union(*(f["loaded"] for f in files.values())) if files else set()
    lines = ["## Tests", "", f"`{run['command']}`: exit {run['returncode']}, wall {run['wall_s']:.0f} s, "
             f"CPU {run['cpu_s']:.0f} s; load average before {run['load_before']}, after {run['load_after']}; "
             f"{counts(loaded, modules)}, {sum(f['cpu_s'] for f in files.values()):.0f} CPU s of compiling; "
             f"{waits(records)}; {repeated_compiles(records)}.", "",
             "| test file | tests | wall s | modules loaded | engine modules loaded | compiled | compile wall s "
             "| compile CPU s | waits | waited s |",
             "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |"]
    names = sorted(set(times) | set(files), key=lambda n: -times.get(n, (0.0, 0))[0])
    for name in names:
        seconds, count = times.get(name, (float("nan"), 0))
        entry = files.get(name, new_entry())
        lines.append(f"| {name} | {count} | {seconds:.1f} | {len(entry['loaded'])} | {sum(map(is_engine, entry['loaded']))} | {len(entry['modules'])} | {entry['wall_s']:.1f} "
                     f"| {entry['cpu_s']:.1f} | {entry['waits']} | {entry['waited_s']:.1f} |")
    lines += ["", *module_table(records, test_file), ""]
    return lines


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--configfile", nargs="+", metavar="FILE", help="config overlays (default: config.yaml alone)")
    parser.add_argument("--targets", nargs="+", default=[], help="Snakemake targets (default: all)")
    parser.add_argument("--cores", default="2", help="snakemake --cores (default 2, the reference machine)")
    parser.add_argument("--rerun", action="store_true", help="then rerun the workflow, forced, on the warm cache")
    parser.add_argument("--no-workflow", action="store_true", help="skip the workflow")
    parser.add_argument("--no-tests", action="store_true", help="skip the tests")
    parser.add_argument("--tests", nargs="+", default=[], metavar="PATH", help="test paths (default: all)")
    parser.add_argument("-m", dest="marker", help="pytest -m expression")
    parser.add_argument("-n", dest="workers", help="pytest-xdist's -n: worker processes, 0 for one process "
                        "(default: pyproject's addopts, a worker per core)")
    parser.add_argument("--per-file", action="store_true", help="one pytest process per test file: the modules "
                        "each file loads, not only those it loads first")
    parser.add_argument("--tests-cold", action="store_true", help="empty the cache before the tests too")
    parser.add_argument("--shared-cache", action="store_true", help="use this machine's engine cache instead of an "
                        "empty one: which modules each job or test loads, without compiling them again")
    parser.add_argument("--folder", type=Path, help="where to work (default: a new temporary folder, kept)")
    parser.add_argument("--output", type=Path, help="also write the Markdown report here")
    args = parser.parse_args(argv)

    folder = args.folder or Path(tempfile.mkdtemp(prefix="ldpipe-cold-"))
    folder.mkdir(parents=True, exist_ok=True)
    cache = folder / "cache"

    def empty_cache() -> dict:
        shutil.rmtree(cache, ignore_errors=True)
        (cache / "numba").mkdir(parents=True)
        return {**os.environ, "LDPIPE_CACHE_DIR": str(cache / "ldpipe"), "NUMBA_CACHE_DIR": str(cache / "numba"),
                "PATH": f"{BIN}{os.pathsep}{os.environ.get('PATH', '')}"}

    env = {**os.environ, "PATH": f"{BIN}{os.pathsep}{os.environ.get('PATH', '')}"} if args.shared_cache else empty_cache()
    report = ["# Cold start", "", f"Machine: {cpu_model()}, {os.cpu_count()} cores; Python {platform.python_version()}; "
              f"working folder {folder}; pip install not included; "
              f"{'the shared engine cache' if args.shared_cache else 'an empty engine cache'}.", ""]
    if not args.no_workflow:
        work = folder / "workflow"
        shutil.rmtree(work, ignore_errors=True)
        work.mkdir()
        for name in WORKFLOW_FILES:
            shutil.copy(ROOT / name, work / name)
        for name in WORKFLOW_FOLDERS:
            shutil.copytree(ROOT / name, work / name)
        command = [str(BIN / "snakemake"), "--cores", args.cores, *args.targets]
        if args.configfile:
            command += ["--configfile", *[str(Path(f).resolve()) for f in args.configfile]]
        log = folder / "workflow_compiles.jsonl"
        log.unlink(missing_ok=True)
        run = timed(command, work, {**env, "LDPIPE_COMPILE_LOG": str(log)}, folder / "workflow_output.txt")
        report += workflow_section(work, run, read_log(log), "Workflow, cold")
        if args.rerun:
            log = folder / "workflow_rerun_compiles.jsonl"
            log.unlink(missing_ok=True)
            run = timed(command + ["--forceall"], work, {**env, "LDPIPE_COMPILE_LOG": str(log)},
                        folder / "workflow_rerun_output.txt")
            report += workflow_section(work, run, read_log(log), "Workflow, forced rerun on the warm cache")
    if not args.no_tests:
        if args.tests_cold and not args.shared_cache:
            env = empty_cache()
        log = folder / "tests_compiles.jsonl"
        log.unlink(missing_ok=True)
        junit = folder / "tests_junit.xml"
        command = [str(BIN / "pytest"), "-q", "-p", "no:cacheprovider", f"--junitxml={junit}"]
        if args.marker:
            command += ["-m", args.marker]
        if args.workers is not None:
            command += ["-n", args.workers]
        if not args.per_file:
            run = timed(command + args.tests, ROOT, {**env, "LDPIPE_COMPILE_LOG": str(log)}, folder / "tests_output.txt")
            report += tests_section(run, read_log(log), [junit])
        else:
            runs, junits = [], []
            for k, path in enumerate(test_files(args.tests)):
                junits.append(folder / f"tests_junit_{k}.xml")
                command[4] = f"--junitxml={junits[-1]}"
                runs.append(timed(command + [path], ROOT, {**env, "LDPIPE_COMPILE_LOG": str(log)},
                                  folder / f"tests_output_{k}.txt"))
            run = {"command": " ".join(command[:4] + command[5:]) + " FILE, one process per file",
                   "returncode": max(r["returncode"] for r in runs), "wall_s": sum(r["wall_s"] for r in runs),
                   "cpu_s": sum(r["cpu_s"] for r in runs), "load_before": runs[0]["load_before"],
                   "load_after": runs[-1]["load_after"]}
            report += tests_section(run, read_log(log), junits)
    text = "\n".join(report)
    print(text)
    if args.output:
        args.output.write_text(text + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
