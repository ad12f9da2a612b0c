"""wbik's compiled kernels (``_<name>.c``) and their Python twins (:mod:`wbik.kernels.twins`)."""
