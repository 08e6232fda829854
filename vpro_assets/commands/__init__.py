"""Subcommands of `vpro`, one module per concept."""
