"""``contactrig`` subcommands of the rig simulation (``sims.rig``) (registered by ``daq.cli``)."""

from __future__ import annotations

import argparse


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add this package's subcommands to ``subparsers``."""
