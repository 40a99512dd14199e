"""The fuzz command's families (benchmarks/fuzz_inputs.py), loaded for the tests: the tests draw
their examples with hypothesis and check each by the command's own checks."""

import importlib.util

from support.workflow import ROOT

_spec = importlib.util.spec_from_file_location("fuzz_inputs", ROOT / "benchmarks" / "fuzz_inputs.py")
fuzz_inputs = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(fuzz_inputs)
