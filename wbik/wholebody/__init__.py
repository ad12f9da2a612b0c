"""Whole-body problems (:class:`~wbik.wholebody.problem.WholeBody`) and seeded case samplers."""
