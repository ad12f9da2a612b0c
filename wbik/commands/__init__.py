"""The ``wbik`` command's subcommands, one module each (:mod:`wbik.cli` lists them)."""
