"""Whole-body problems (:class:`~wbik.wholebody.problem.WholeBody`) and the study's seeded case samplers
(:mod:`wbik.wholebody.cases`)."""
