"""The comparison study (the Golem-III thesis's custom-vs-KDL study, across methods and robots).

``definition`` (study files), ``sampling`` (poses), ``runner`` (chunks, joblib/Dask, resume),
``results`` (files on disk), ``metrics`` (per-axis errors), ``statistics`` (summary, Mann-Whitney),
``figures`` and ``report`` (Markdown + self-contained HTML).

>>> from wbik.study import load_study, run_study
>>> run_study(load_study("comparisons/default.yaml").with_overrides(poses=50))  # doctest: +SKIP
"""

from wbik.study.definition import (
           CaseSpec,
           MethodSpec,
           Study,
           StudyDefinitionError,
           load_study,
           study_from_dict,
)
from wbik.study.runner import run_study

__all__ = ["CaseSpec", "MethodSpec", "Study", "StudyDefinitionError", "load_study", "run_study",
           "study_from_dict"]
