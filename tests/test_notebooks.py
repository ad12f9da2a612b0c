"""The notebooks in notebooks/ run top to bottom (nbclient), each with a per-cell timeout.

The kernel is the interpreter running the tests (the venv's python, started from a kernel spec
written to a temporary folder, so a fresh clone needs no ``jupyter kernelspec install``). The test
process runs with MPLBACKEND=Agg; the kernel uses matplotlib's inline backend (Agg rendering, no
display), so the executed copies keep their figures. A failing cell fails the test with that cell's
traceback. The executed copies go to tests/artifacts/notebooks/ (git-ignored), also when a cell
fails. The notebooks assert the seed numbers they reproduce, so an executed notebook is a test too.

The generated notebooks (scripts/make_notebooks.py) must be committed as generated, without outputs.
"""

from __future__ import annotations

import importlib.util
import json
import re
import sys
from pathlib import Path

import nbclient
import nbformat
import pytest
from jupyter_client.kernelspec import KernelSpecManager
from jupyter_client.manager import KernelManager
from nbclient.exceptions import CellExecutionError

ROOT = Path(__file__).resolve().parents[1]
NOTEBOOKS = ROOT / "notebooks"
ARTIFACTS = ROOT / "tests" / "artifacts" / "notebooks"
CELL_TIMEOUT_S = 180
KERNEL_NAME = "wbik-venv"
ANSI_ESCAPE = re.compile(r"\x1b\[[0-9;]*m")


def _notebooks() -> list[Path]:
    return sorted(NOTEBOOKS.glob("*.ipynb"))


@pytest.fixture(scope="module")
def kernel_specs(tmp_path_factory) -> KernelSpecManager:
    """A kernel spec that starts ipykernel with this very interpreter (the venv's python)."""
    folder = tmp_path_factory.mktemp("kernels")
    spec = folder / KERNEL_NAME
    spec.mkdir()
    (spec / "kernel.json").write_text(json.dumps({
        "argv": [sys.executable, "-m", "ipykernel_launcher", "-f", "{connection_file}"],
        "display_name": "wbik (venv)",
        "language": "python",
        # headless: matplotlib renders with Agg and the inline backend stores PNGs in the outputs
        "env": {"MPLBACKEND": "module://matplotlib_inline.backend_inline", "PYTHONHASHSEED": "0"},
    }))
    return KernelSpecManager(kernel_dirs=[str(folder)])


def test_there_are_notebooks():
    names = [path.name for path in _notebooks()]
    for expected in ("01_quickstart.ipynb", "04_pincher.ipynb", "05_newton_path.ipynb"):
        assert expected in names


@pytest.mark.parametrize("path", _notebooks(), ids=lambda path: path.stem)
def test_notebook_runs_top_to_bottom(path: Path, kernel_specs: KernelSpecManager, monkeypatch):
    monkeypatch.setenv("MPLBACKEND", "Agg")
    notebook = nbformat.read(path, as_version=4)
    manager = KernelManager(kernel_name=KERNEL_NAME, kernel_spec_manager=kernel_specs)
    client = nbclient.NotebookClient(notebook, km=manager, timeout=CELL_TIMEOUT_S, kernel_name=KERNEL_NAME,
                                     resources={"metadata": {"path": str(NOTEBOOKS)}})
    ARTIFACTS.mkdir(parents=True, exist_ok=True)
    try:
        client.execute()
    except CellExecutionError as error:
        pytest.fail(f"{path.name}: a cell failed\n{ANSI_ESCAPE.sub('', str(error))}", pytrace=False)
    finally:
        nbformat.write(notebook, ARTIFACTS / path.name)
    code_cells = [cell for cell in notebook.cells if cell.cell_type == "code"]
    assert code_cells and all(cell.get("execution_count") for cell in code_cells)
    errors = [output for cell in code_cells for output in cell.outputs if output.output_type == "error"]
    assert not errors


def _generator():
    spec = importlib.util.spec_from_file_location("make_notebooks", ROOT / "scripts" / "make_notebooks.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_generated_notebooks_are_committed_as_generated_without_outputs():
    generator = _generator()
    for name, built in generator.build_all().items():
        path = NOTEBOOKS / name
        assert path.exists(), f"{name} missing: run .venv/bin/python scripts/make_notebooks.py"
        committed = nbformat.read(path, as_version=4)
        assert [cell.source for cell in committed.cells] == [cell.source for cell in built.cells], (
            f"{name} differs from scripts/make_notebooks.py: regenerate it")
        for cell in committed.cells:
            if cell.cell_type == "code":
                assert not cell.outputs and cell.execution_count is None, f"{name} is committed with outputs"
