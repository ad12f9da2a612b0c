"""The ``wbik`` command's subcommands, one module each (:mod:`wbik.cli` lists them), and the arguments
several of them take (:mod:`wbik.commands.arguments`)."""
