"""Equilibria: of a potential (saddles, wells, spectra) and of a general flow."""
