"""Lagrangian-descriptor and FTLE maps: grids, adaptive sampling, reversing symmetries."""
