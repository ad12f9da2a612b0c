"""The comparison study: IK methods on the same random reachable targets of any robot, judged by one
FK check, beside the figures of a published reference when the study file gives them.

``definition`` (study files), ``sampling`` (poses), ``runner`` (chunks, joblib/Dask, resume),
``applicability`` (which methods apply to a case), ``results`` (files on disk), ``metrics``
(per-axis errors, Euler angles), ``statistics`` (summary, Mann-Whitney), ``reference`` (the figures
a study compares with), ``figures`` and ``report`` (Markdown + self-contained HTML), ``wholebody``
(whole-body cases).

>>> from wbik.study import load_study, run_study
>>> run_study(load_study("comparisons/default.yaml").with_overrides(poses=50))  # doctest: +SKIP
"""

from wbik.study.definition import CaseSpec
from wbik.study.definition import MethodSpec
from wbik.study.definition import Study
from wbik.study.definition import StudyDefinitionError
from wbik.study.definition import load_study
from wbik.study.definition import study_from_dict
from wbik.study.runner import run_study

__all__ = ["CaseSpec", "MethodSpec", "Study", "StudyDefinitionError", "load_study", "run_study",
           "study_from_dict"]
