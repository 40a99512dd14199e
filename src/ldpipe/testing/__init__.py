"""Independent references for tests and benchmarks (as numpy.testing and xarray.testing are).

``reference_ld`` computes LDs with scipy alone, sharing no code with the engine.
"""
