"""The documentation site builds with ``mkdocs build --strict`` (every page, every link inside the site,
the API reference from the docstrings, the tutorials from the notebooks, the task-file tables from the
schemas), and no page speaks of how the project was developed."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def test_the_site_builds_strictly(tmp_path):
    done = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(tmp_path)],
                          cwd=ROOT, capture_output=True, text=True, timeout=300,
                          env={"NO_MKDOCS_2_WARNING": "1", "PATH": "/usr/bin:/bin"})
    assert done.returncode == 0, done.stderr[-3000:]
    task_files = (tmp_path / "formats" / "task-files" / "index.html").read_text()
    assert "kind: wholebody_ik" in task_files and "phases[].tasks[]" in task_files
    reference = (tmp_path / "reference" / "solvers" / "index.html").read_text()
    assert "bounded_lm" in reference and "IKResult" in reference
    tutorial = (tmp_path / "tutorials" / "01_quickstart" / "index.html").read_text()
    assert "Quickstart" in tutorial and "golem3" in tutorial  # text and code cells of the notebook


def test_no_page_tells_the_history_of_its_making():
    words = re.compile(r"\b(this|last|previous|earlier|next) session\b|\bsession \d|\bin the \w+ session",
                       re.IGNORECASE)
    pages = [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]
    offending = [f"{page.relative_to(ROOT)}: {match.group(0)}" for page in pages
                 for match in words.finditer(page.read_text(encoding="utf-8"))]
    assert not offending, offending
