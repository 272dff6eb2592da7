"""Shared infrastructure under every package: validation, the scene reader, provenance.

Imports only the standard library and numpy.
"""
