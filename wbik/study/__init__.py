"""The comparison study: IK methods on the same random reachable targets of any robot, judged by one
FK check, beside the figures of a published reference when the study file gives them.

``definition`` (study files), ``case_kinds`` (what a kind of case does, and their registry),
``chain_targets`` (the kinds ``pose`` and ``position``: targets of one chain), ``wholebody`` (the
kind ``wholebody``: whole-body cases), ``sampling`` (poses), ``context`` (what the runner, the kinds
and the report share), ``runner`` (chunks, joblib/Dask, resume), ``cpu_watch`` (wall-clock solves
re-run when starved of CPU), ``applicability`` (which methods apply to a case), ``results`` (files
on disk), ``ownership`` (the output folder's lock), ``metrics`` (per-axis errors, Euler angles),
``statistics`` (summary, intervals, Mann-Whitney with Holm's correction), ``reference`` (the figures
a study compares with), ``budget_curves`` (success versus budget), ``figures``, ``blocks`` (what
every kind's report section is made of), ``report`` (Markdown + self-contained HTML), ``provenance``
(what made a run's rows: version, commit, machine, command, code fingerprint), ``compare`` (the paired
regression gate of ``--compare-to``) and ``regression_rule`` (its rule).

>>> from wbik.study import load_study, run_study
>>> run_study(with_overrides(load_study("comparisons/default.yaml"), poses=50))  # doctest: +SKIP
"""

from wbik.study.definition import load_study
from wbik.study.definition import study_from_dict
from wbik.study.definition import with_overrides
from wbik.study.runner import run_study
from wbik.study.spec import CaseSpec
from wbik.study.spec import MethodSpec
from wbik.study.spec import Study
from wbik.study.spec import StudyDefinitionError

__all__ = ["CaseSpec", "MethodSpec", "Study", "StudyDefinitionError", "load_study", "run_study",
           "study_from_dict", "with_overrides"]
