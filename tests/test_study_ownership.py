"""A study run owns its output folder: one run at a time, --fresh never deletes a held folder,
temporaries of killed writers are removed, and killing the main process leaves no worker behind."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from wbik.study import load_study, run_study
from wbik.study.ownership import LOCK_NAME, FolderBusyError, FolderLock

ROOT = Path(__file__).resolve().parents[1]
WBIK = str(Path(sys.executable).with_name("wbik"))

STUDY = """
name: ownership
figures: false
robot: golem3
chain: right_arm
target: pose
poses: {poses}
seed: 3
start: nominal
chunk_size: 10
baseline: dls
methods:
  - {{method: dls, options: {{max_iterations: 30}}}}
  - {{method: newton, options: {{max_iterations: 30}}}}
"""

HOLD_LOCK = """
import sys, time
from wbik.study.ownership import FolderLock
with FolderLock(sys.argv[1]):
    print("held", flush=True)
    time.sleep(60)
"""


def _study_file(tmp_path: Path, poses: int) -> Path:
    path = tmp_path / "study.yaml"
    path.write_text(STUDY.format(poses=poses))
    return path


@pytest.fixture
def held_folder(tmp_path):
    """A folder whose lock another process holds."""
    folder = tmp_path / "out"
    holder = subprocess.Popen([sys.executable, "-c", HOLD_LOCK, str(folder)], stdout=subprocess.PIPE,
                              text=True)
    assert holder.stdout.readline().strip() == "held"
    yield folder, holder
    holder.kill()
    holder.wait()


def test_a_second_run_refuses_and_fresh_deletes_nothing(tmp_path, held_folder):
    folder, holder = held_folder
    precious = folder / "results_of_the_other_run.npz"
    precious.write_bytes(b"rows")
    study = load_study(_study_file(tmp_path, 20))
    with pytest.raises(FolderBusyError, match=f"pid {holder.pid}"):
        run_study(study, folder, jobs=1, fresh=True, progress=False)
    assert precious.read_bytes() == b"rows"
    # the command line says so with exit code 2 (bad usage), without a traceback
    done = subprocess.run([WBIK, "study", str(_study_file(tmp_path, 20)), "--output", str(folder), "--fresh",
                           "--no-progress"], capture_output=True, text=True, cwd=tmp_path)
    assert done.returncode == 2 and "in use by another wbik study run" in done.stderr
    assert "Traceback" not in done.stderr
    assert precious.exists()


def test_the_lock_is_released_with_the_run_and_fresh_keeps_the_lock_file(tmp_path):
    study = load_study(_study_file(tmp_path, 20))
    folder = tmp_path / "out"
    run_study(study, folder, jobs=1, progress=False, report=False)
    run_study(study, folder, jobs=1, fresh=True, progress=False, report=False)  # not refused: released
    assert (folder / LOCK_NAME).exists() and (folder / "study.json").exists()
    with FolderLock(folder) as lock:
        lock.clear()
    assert [p.name for p in folder.iterdir()] == [LOCK_NAME]


def test_resume_removes_temporaries_of_killed_writers(tmp_path):
    study = load_study(_study_file(tmp_path, 20))
    folder = tmp_path / "out"
    run_study(study, folder, jobs=1, progress=False, report=False)
    chunks = folder / "golem3_right_arm_pose" / "chunks" / "dls"
    stale = chunks / ".chunk_00001.npz.99999.tmp"
    stale.write_bytes(b"half a chunk")
    run_study(study, folder, jobs=1, progress=False, report=False)
    assert not stale.exists()


def _children(pid: int) -> list[int]:
    found = []
    for task in Path(f"/proc/{pid}/task").iterdir():
        text = (task / "children").read_text().split()
        found += [int(child) for child in text]
    return found


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    state = Path(f"/proc/{pid}/stat").read_text().split(") ")[-1].split()[0]
    return state != "Z"


@pytest.mark.parametrize("signal_number", [signal.SIGTERM, signal.SIGINT, signal.SIGKILL])
def test_killing_the_main_process_leaves_no_worker(tmp_path, signal_number):
    study = _study_file(tmp_path, 4000)
    main = subprocess.Popen([WBIK, "study", str(study), "--output", str(tmp_path / "out"), "--jobs", "2",
                             "--no-progress"], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                            start_new_session=True)
    try:
        workers: list[int] = []
        deadline = time.monotonic() + 60
        while len(workers) < 2 and time.monotonic() < deadline:  # wait for the loky workers
            time.sleep(0.2)
            workers = [p for p in _children(main.pid)
                       if "loky" in Path(f"/proc/{p}/cmdline").read_text(errors="replace")]
        assert len(workers) >= 2, "the study never started its workers"
        everyone = set(_children(main.pid))
        main.send_signal(signal_number)
        main.wait(timeout=30)
        deadline = time.monotonic() + 10
        while any(_alive(p) for p in everyone) and time.monotonic() < deadline:
            time.sleep(0.2)
        assert not [p for p in everyone if _alive(p)], "processes outlived the study's main process"
    finally:
        try:
            os.killpg(main.pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
