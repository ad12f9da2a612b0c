"""wbik's compiled kernels (``_<name>.c`` beside this file) and their Python twins: :mod:`wbik.kernels.twins`
lists them and picks which runs."""
