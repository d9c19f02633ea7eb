"""Subcommands of the ``optdesign`` command (one module each, see optdesign.cli)."""
