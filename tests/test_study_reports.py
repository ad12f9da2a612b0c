"""Reports that say what made them (wbik.study.provenance): the code fingerprint follows imports, function
imports and compiled kernels but not TYPE_CHECKING blocks, ignores docstrings and comments, and sees code
edits; each committed report (comparisons/reports/NAME/, made by scripts/make_reports.sh) records what
made it and is not older than the code its rows come from.

The last test fails while a committed report predates a change to that code: the message names the
changed modules; regenerate the report (the lead regenerates them all with scripts/make_reports.sh)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from wbik.study import load_study, provenance
from wbik.study.definition import COMPARISONS_DIR
from wbik.study.provenance import code_digests
from wbik.study.runner import study_code_roots

REPORTS = Path(__file__).resolve().parents[1] / "comparisons" / "reports"
NAMES = sorted(folder.name for folder in REPORTS.iterdir() if folder.is_dir())
REGENERATE = "regenerate it: scripts/make_reports.sh {name} (comparisons/reports/README.md)"

A = '''"""Module a."""
from typing import TYPE_CHECKING
import numpy

if TYPE_CHECKING:
    from wbik.c import Typing

import wbik.d as d
import wbik.kernels._k as compiled
import wbik.kernels._x as compiled_cxx


def f():
    """Lazily."""
    from wbik import b
    return b.g() + 1
'''
B = '''def g():
    """Two."""
    return 2
'''


@pytest.fixture()
def package(tmp_path, monkeypatch) -> Path:
    root = tmp_path / "wbik"
    files = {"__init__.py": "", "a.py": A, "b.py": B, "c.py": "X = 1\n", "d.py": "class Thing: ...\n",
             "kernels/__init__.py": "", "kernels/_k.c": '#include "_h.h"\nint k;\n',
             "kernels/_x.cpp": '#include "_h.h"\nint x;\n',
             "kernels/_h.h": "int h;\n"}
    for name, text in files.items():
        (root / name).parent.mkdir(parents=True, exist_ok=True)
        (root / name).write_text(text)
    monkeypatch.setattr(provenance, "PACKAGE", root)
    return root


def test_the_fingerprint_follows_imports_and_kernels_not_typing(package):
    assert set(code_digests(["wbik.a"])) == {"wbik.a", "wbik.b", "wbik.d", "kernels/_k.c", "kernels/_x.cpp",
                                             "kernels/_h.h"}


def test_words_do_not_change_the_fingerprint_and_code_does(package):
    before = code_digests(["wbik.a"])
    (package / "b.py").write_text('def g():\n    """Two, said otherwise."""\n    # a comment\n    return 2\n')
    (package / "a.py").write_text(A.replace('"""Module a."""', '"""Module a, reworded."""'))
    assert code_digests(["wbik.a"]) == before
    (package / "b.py").write_text(B.replace("return 2", "return 3"))
    after = code_digests(["wbik.a"])
    assert {name for name in before if before[name] != after[name]} == {"wbik.b"}
    (package / "kernels" / "_h.h").write_text("int h2;\n")
    assert code_digests(["wbik.a"])["kernels/_h.h"] != after["kernels/_h.h"]


def test_a_study_s_code_is_its_methods_robots_and_runner():
    """The default study (Golem-III, chain methods): its methods' solvers, the robot's model and its closed
    form (bound by name), the runner and the kernels; not a method or a case kind it does not use."""
    study = load_study(COMPARISONS_DIR / "default.yaml")
    digests = code_digests(study_code_roots(study))
    assert {"wbik.solvers.bounded_lm", "wbik.solvers.tracik", "wbik.robot_packages.golem3.model",
            "wbik.robot_packages.golem3.closed_form", "wbik.apps.golem3.thesis_solvers", "wbik.study.runner",
            "wbik.study.chain_targets", "kernels/_lm_trial.c", "kernels/_chain_fk.cpp",
            "kernels/_checked_errors.h"} <= set(digests)
    unused = {"wbik.solvers.mink", "wbik.solvers.eaik", "wbik.study.paths", "wbik.study.wholebody"}
    assert not unused & set(digests)


@pytest.mark.parametrize("name", NAMES)
def test_a_committed_report_is_not_older_than_the_code_of_its_rows(name):
    """A committed report records what made it (provenance.json, and the report's head says it), and its
    code fingerprint is today's: else it is stale, and the message says what changed since."""
    regenerate = REGENERATE.format(name=name)
    path = REPORTS / name / "provenance.json"
    assert path.is_file(), (f"comparisons/reports/{name} has no provenance.json (nothing says what made it); "
                            + regenerate)
    record = json.loads(path.read_text())
    head = (REPORTS / name / "report.md").read_text().split("## Methods")[0]
    machine = record["machine"]
    for words in (record["command"], str(record["commit"]), machine["cpu"], record["code_fingerprint"]):
        assert words in head, f"comparisons/reports/{name}/report.md does not say {words!r}; " + regenerate
    today = code_digests(study_code_roots(load_study(COMPARISONS_DIR / f"{name}.yaml")))
    changed = sorted(key for key in today.keys() | record["code"].keys()
                     if today.get(key) != record["code"].get(key))
    assert not changed, (f"comparisons/reports/{name} is older than the code its rows come from; changed "
                         f"since it was made: {', '.join(changed)}; " + regenerate)
