"""Periodic orbits, their invariant manifolds, and Poincaré sections."""
