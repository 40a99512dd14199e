"""Velocity data for examples: analytic flows written as CF netCDF files (no third-party data shipped)."""
