"""The notebooks in notebooks/ run top to bottom (nbclient), each with a per-cell timeout.

The kernel is the interpreter running the tests (the venv's python, started from a kernel spec
written to a temporary folder, so a fresh clone needs no ``jupyter kernelspec install``). The test
process runs with MPLBACKEND=Agg; the kernel uses matplotlib's inline backend (Agg rendering, no
display), so the executed copies keep their figures. A failing cell fails the test with that cell's
traceback. The executed copies go to tests/artifacts/notebooks/ (git-ignored), also when a cell
fails. The notebooks assert the seed numbers they reproduce, so an executed notebook is a test too.

The notebooks are plain sources: jupytext percent scripts ``notebooks/NN_name.py`` (cells start at
``# %%``, markdown cells at ``# %% [markdown]``), linted by ruff like the rest of the code and
converted to notebooks here with jupytext. No .ipynb is committed: the set-up pairs each script with
the .ipynb JupyterLab opens (``notebooks/jupytext.toml``), and saving either updates the other.
"""

from __future__ import annotations

import json
import re
import sys
from pathlib import Path

import jupytext
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
    return sorted(NOTEBOOKS.glob("[0-9][0-9]_*.py"))


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
    for expected in ("01_quickstart.py", "04_pincher.py", "05_newton_path.py", "06_ur5_riveting.py"):
        assert expected in names


def test_notebooks_are_percent_scripts_without_committed_copies():
    """Every notebook is a jupytext percent script with code cells; no .ipynb is committed (the set-up
    makes them, git ignores them)."""
    import subprocess

    tracked = subprocess.run(["git", "ls-files", "--", "*.ipynb"], cwd=NOTEBOOKS, capture_output=True,
                             text=True, check=True).stdout.split()
    assert not tracked, f"committed notebooks {tracked}: commit the .py sources only"
    for path in _notebooks():
        assert path.read_text().startswith("# %%"), f"{path.name}: a percent script starts with a '# %%' cell"
        notebook = jupytext.read(path)
        assert any(cell.cell_type == "code" for cell in notebook.cells), path.name
        assert any(cell.cell_type == "markdown" for cell in notebook.cells), path.name


@pytest.mark.parametrize("path", _notebooks(), ids=lambda path: path.stem)
def test_notebook_runs_top_to_bottom(path: Path, kernel_specs: KernelSpecManager, monkeypatch):
    monkeypatch.setenv("MPLBACKEND", "Agg")
    notebook = jupytext.read(path)  # the percent script as an output-free notebook
    manager = KernelManager(kernel_name=KERNEL_NAME, kernel_spec_manager=kernel_specs)
    client = nbclient.NotebookClient(notebook, km=manager, timeout=CELL_TIMEOUT_S, kernel_name=KERNEL_NAME,
                                     resources={"metadata": {"path": str(NOTEBOOKS)}})
    ARTIFACTS.mkdir(parents=True, exist_ok=True)
    try:
        client.execute()
    except CellExecutionError as error:
        pytest.fail(f"{path.name}: a cell failed\n{ANSI_ESCAPE.sub('', str(error))}", pytrace=False)
    finally:
        nbformat.write(notebook, ARTIFACTS / f"{path.stem}.ipynb")
    code_cells = [cell for cell in notebook.cells if cell.cell_type == "code"]
    assert code_cells and all(cell.get("execution_count") for cell in code_cells)
    errors = [output for cell in code_cells for output in cell.outputs if output.output_type == "error"]
    assert not errors


def test_every_notebook_opens_in_jupyterlab_as_a_notebook_paired_with_its_script():
    """After the README's set-up, ``.venv/bin/jupyter lab notebooks/`` shows each script as a notebook:
    its paired .ipynb holds the script's cells, and JupyterLab runs jupytext's extension (which saves a
    notebook back to its script)."""
    import subprocess

    bin_folder = Path(sys.executable).parent
    for script in _notebooks():
        paired = script.with_suffix(".ipynb")
        assert paired.is_file(), f"{paired.name} missing: run bash scripts/setup.sh"
        source, notebook = jupytext.read(script), jupytext.read(paired)
        assert [(c.cell_type, c.source) for c in source.cells] == \
            [(c.cell_type, c.source) for c in notebook.cells], f"{paired.name} differs from {script.name}"
    extensions = subprocess.run([str(bin_folder / "jupyter"), "server", "extension", "list"],
                                capture_output=True, text=True, check=True)
    found = ANSI_ESCAPE.sub("", extensions.stdout + extensions.stderr)
    assert re.search(r"jupyterlab\s+enabled", found) and re.search(r"jupyterlab_jupytext\s+enabled", found)
