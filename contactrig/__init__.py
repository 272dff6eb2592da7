"""contactrig's shared layers: ``contactrig.core`` (below every package) and ``contactrig.cli`` (above them all).

This package imports nothing itself, so ``import contactrig.core.validation`` from ``sims`` or ``instruments`` pulls
in neither the CLI nor any other package. The allowed import directions are in README.md, "Architecture", and are
enforced by ``tests/test_architecture.py``.
"""
