"""What reading the configuration schema costs a caller: ``ldpipe.config.load_schema()`` per
call (what every plot's figure defaults, ``ldpipe.figures.dataset``, and the tests asked for on
each use), the median of ``--calls`` calls after a first one, and that first call.

Run it on two checkouts to compare (``PYTHONPATH=OLD/src`` then ``PYTHONPATH=src``); the schema's
size is printed so that the runs can be matched.
"""

from __future__ import annotations

import argparse
import statistics
import time


def seconds(function) -> float:
    start = time.perf_counter()
    function()
    return time.perf_counter() - start


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--calls", type=int, default=50, help="calls timed after the first (default 50)")
    arguments = parser.parse_args()

    from importlib import resources

    import ldpipe
    from ldpipe.config import SCHEMA_RESOURCE, load_schema

    text = resources.files(SCHEMA_RESOURCE[0]).joinpath(SCHEMA_RESOURCE[1]).read_text()
    print(f"ldpipe from {ldpipe.__file__}; schema of {len(text)} characters")
    first = seconds(load_schema)
    later = statistics.median(seconds(load_schema) for _ in range(arguments.calls))
    print(f"load_schema(): first call {first * 1e3:.2f} ms, later calls {later * 1e3:.3f} ms (median of "
          f"{arguments.calls})")


if __name__ == "__main__":
    main()
