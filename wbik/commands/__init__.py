"""Subcommands of the ``wbik`` CLI, one module each (see :mod:`wbik.cli`)."""
