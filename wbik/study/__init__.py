"""The comparison study: IK methods on the same random reachable targets of any robot, judged by one FK
check, beside the figures of a published reference when the study file gives them (docs/guide/studies.md).

>>> from wbik.study import load_study, run_study
>>> run_study(with_overrides(load_study("comparisons/default.yaml"), poses=50))  # doctest: +SKIP
"""

from wbik.study.definition import load_study, study_from_dict, with_overrides
from wbik.study.runner import run_study
from wbik.study.spec import CaseSpec, MethodSpec, Study, StudyDefinitionError

__all__ = ["CaseSpec", "MethodSpec", "Study", "StudyDefinitionError", "load_study", "run_study",
           "study_from_dict", "with_overrides"]
