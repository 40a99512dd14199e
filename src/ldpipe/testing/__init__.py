"""Independent references for tests and benchmarks (as numpy.testing and xarray.testing are).

``reference_ld`` computes LDs with scipy alone, sharing no code with the engine; ``fuzz`` makes
bad input on purpose (configurations one key off, corrupted velocity-data files) and checks that
it is refused by name (the tests in tests/fuzz/ and ``benchmarks/fuzz_inputs.py``).
"""
