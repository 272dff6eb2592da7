"""Bench sessions: Delta-mode resistance per added weight, logged to HDF5, resumed, replayed, imported."""
