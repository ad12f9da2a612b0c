"""Small studies through the CLI and the runner: files, summary vs raw rows, Mann-Whitney vs scipy,
"not applicable" methods, resume after a kill, serial = parallel (= Dask)."""

from __future__ import annotations

import multiprocessing
import os
import signal
import time
from pathlib import Path

import numpy as np
import pytest
from scipy import stats

import wbik
from wbik.cli import main
from wbik.solvers.dls import DampedLeastSquares
from wbik.study import load_study, run_study
from wbik.study.results import load_method_rows, read_raw_csv

STUDY = """
name: small
poses: 200
seed: 11
chunk_size: 50
timeout_s: 1.0
baseline: analytic
cases:
  - robot: ur5
    chain: arm
    target: pose
    reference:
      name: paper
      source: "a made-up Table 2"
      angles: {sequence: zyx, names: {x: paper_yaw, z: paper_roll}}
      figures:
        analytic: {percent_solved: 99.0, time_median_ms: 1000.0}
        kdl: {percent_solved: 10.0}
      significance_source: "Table 3"
      significance:
        kdl: {x: 0.5, paper_roll: 0.001, time: 0}
      notes: "Invented figures."
  - {robot: arm3r, chain: arm, target: position}
methods:
  - analytic
  - {method: dls, options: {max_iterations: 60}}
  - kdl
"""


def _write(folder: Path, text: str, name: str = "small.yaml") -> Path:
    path = folder / name
    path.write_text(text)
    return path


@pytest.fixture(scope="module")
def serial_run(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("study")
    study_file = _write(folder, STUDY)
    assert main(["study", str(study_file), "-o", str(folder / "out"), "--backend", "sequential",
                 "--no-progress"]) == 0
    return folder / "out"


def _same_rows(first: dict, second: dict) -> None:
    assert set(first) == set(second)
    for label in first:
        for column, values in first[label].items():
            if column == "time_s":
                continue
            other = second[label][column]
            if values.dtype.kind == "f":
                assert np.array_equal(values, other, equal_nan=True), (label, column)
            else:
                assert np.array_equal(values, other), (label, column)


def test_files_appear(serial_run):
    for name in ("study.json", "run.json", "report.md", "report.html"):
        assert (serial_run / name).is_file()
    for case in ("ur5_arm_pose", "arm3r_arm_position"):
        for name in ("poses.npz", "raw.csv", "summary.csv", "figures/solved.png", "figures/errors.png",
                     "figures/error_histograms.png", "figures/time.png", "figures/time_histogram.png",
                     "figures/time_ecdf.png"):
            assert (serial_run / case / name).is_file(), (case, name)
    html = (serial_run / "report.html").read_text()
    # 6 figures x 2 cases and analytic's throughput in each, embedded (no budget curves)
    assert html.count("data:image/png;base64,") == 14
    assert (serial_run / "ur5_arm_pose" / "figures" / "throughput.png").is_file()
    assert "src='http" not in html and 'src="http' not in html


def test_a_report_without_figures_has_the_same_tables(serial_run, tmp_path):
    """``--no-figures``: the report's tables, no figure drawn or embedded; the rows and summaries the same
    (a copy of the run, its report rebuilt from its rows)."""
    import shutil

    copy = tmp_path / "out"
    shutil.copytree(serial_run, copy)
    shutil.rmtree(copy / "ur5_arm_pose" / "figures")
    shutil.rmtree(copy / "arm3r_arm_position" / "figures")
    study_file = _write(tmp_path, STUDY)
    assert main(["study", str(study_file), "-o", str(copy), "--report-only", "--no-figures"]) == 0
    html = (copy / "report.html").read_text()
    assert "data:image/png" not in html and "figures/" not in (copy / "report.md").read_text()
    for case in ("ur5_arm_pose", "arm3r_arm_position"):
        assert not (copy / case / "figures").exists()
        for name in ("raw.csv", "summary.csv"):
            assert (copy / case / name).read_bytes() == (serial_run / case / name).read_bytes(), (case, name)
    assert "## Case ur5_arm_pose" in (copy / "report.md").read_text()


def test_the_run_records_what_made_its_rows(serial_run):
    """provenance.json: the version, the commit, the machine, the command and the code fingerprint of the
    study's code as computed from the source; the report's head says them."""
    import json

    import numpy
    import pinocchio

    from wbik.study.provenance import code_digests, code_fingerprint, command_line
    from wbik.study.runner import study_code_roots

    record = json.loads((serial_run / "provenance.json").read_text())
    digests = code_digests(study_code_roots(load_study(serial_run.parent / "small.yaml")))
    assert record["code"] == digests and record["code_fingerprint"] == code_fingerprint(digests)
    assert record["wbik"] == wbik.__version__ and record["machine"]["cpu_count"] == os.cpu_count()
    versions = numpy.__version__, pinocchio.__version__
    assert (record["machine"]["numpy"], record["machine"]["pinocchio"]) == versions
    assert record["command"] == command_line()  # this process's: pytest's here, "wbik study ..." from a shell
    head = (serial_run / "report.md").read_text().split("## Methods")[0]
    for words in (record["command"], record["code_fingerprint"], record["machine"]["cpu"],
                  f"NumPy {numpy.__version__}", f"Pinocchio {pinocchio.__version__}"):
        assert words in head


def test_raw_rows_are_complete_and_reproduce_the_errors(serial_run):
    rows = read_raw_csv(serial_run / "ur5_arm_pose" / "raw.csv")
    assert set(rows) == {"analytic", "dls", "kdl"}
    chain = wbik.load("ur5").chain("arm")
    poses = np.load(serial_run / "ur5_arm_pose" / "poses.npz")
    dls = rows["dls"]
    assert np.array_equal(dls["pose"], np.arange(200))
    for index in np.flatnonzero(dls["success"])[:10]:
        q = np.array([dls[f"q_{name}"][index] for name in chain.joint_names])
        reached = chain.fk(q)
        assert np.allclose(reached.translation - poses["positions"][index],
                           [dls["err_x"][index], dls["err_y"][index], dls["err_z"][index]], atol=1e-15)
        assert dls["position_error"][index] <= 1e-6


def test_not_applicable_methods_are_reported_not_crashed(serial_run):
    report = (serial_run / "report.md").read_text()
    # KDL takes full poses only: on the position-only case it is "not applicable" with the message
    section = report.split("## Case arm3r_arm_position")[1]
    assert "Not applicable to this case" in section
    assert "kdl:" in section
    assert "kdl" not in read_raw_csv(serial_run / "arm3r_arm_position" / "raw.csv")


def test_the_report_sets_our_figures_beside_the_study_file_s_reference(serial_run):
    report = (serial_run / "report.md").read_text()
    section = report.split("### Beside the paper")[1].split("## Case arm3r_arm_position")[0]
    summary = _summary(serial_run / "ur5_arm_pose" / "summary.csv")
    lines = section.splitlines()
    assert lines[2] == "Paper figures from a made-up Table 2."
    assert "| method | metric | paper | ours | comparison |" in lines
    solved = summary["analytic"]["percent_solved"]
    difference = solved - 99.0  # within 2 points: "agrees"
    words = (f"agrees ({difference:+.1f} points)" if abs(difference) <= 2
             else f"differs by {difference:+.1f} points")
    assert f"| analytic | poses solved (%) | 99 | {solved:.3g} | {words} |" in lines
    ratio = summary["analytic"]["time_all_median_ms"] / 1000.0
    assert any(line.startswith("| analytic | median time, all poses (ms) | 1e+03 |")
               and line.endswith(f"| faster (x{ratio:.2g}) |") for line in lines)
    assert ("Mann-Whitney p-values against the baseline, the paper's (Table 3) beside ours; 'same verdict' "
            "compares significance at 0.05.") in lines
    assert "| method | axis | paper p | our p | same verdict |" in lines
    assert any(line.startswith("| kdl | paper_roll | 0.001 |") for line in lines)
    assert "Where and why we differ: Invented figures." in lines
    assert "(repeated under the paper's names: alpha = paper_yaw, gamma = paper_roll)" in report
    assert {"err_paper_yaw_abs_max", "err_paper_roll_abs_max"} <= set(summary["analytic"])
    assert "err_paper_pitch_abs_max" not in summary["analytic"]
    assert "Beside the" not in report.split("## Case arm3r_arm_position")[1]  # no reference there


def _summary(path: Path) -> dict[str, dict[str, float]]:
    import csv

    with open(path, newline="") as handle:
        return {row.pop("method"): {k: float(v) for k, v in row.items()} for row in csv.DictReader(handle)}


def test_summary_matches_the_raw_rows(serial_run):
    for case in ("ur5_arm_pose", "arm3r_arm_position"):
        rows = read_raw_csv(serial_run / case / "raw.csv")
        summary = _summary(serial_run / case / "summary.csv")
        assert set(summary) == set(rows)
        for label, columns in rows.items():
            solved = columns["success"]
            line = summary[label]
            assert line["solved"] == solved.sum()
            assert line["percent_solved"] == pytest.approx(100 * solved.mean())
            times = columns["time_s"] * 1e3
            assert line["time_solved_median_ms"] == pytest.approx(np.median(times[solved]))
            assert line["time_all_max_ms"] == pytest.approx(times.max())
            if (~solved).any():
                assert line["time_unsolved_p95_ms"] == pytest.approx(np.percentile(times[~solved], 95))
            for axis in ("x", "z") + (("alpha",) if case.endswith("pose") else ()):
                errors = columns[f"err_{axis}"][solved]
                assert line[f"err_{axis}_abs_max"] == pytest.approx(np.abs(errors).max())
                assert line[f"err_{axis}_mean"] == pytest.approx(errors.mean())


def test_every_row_is_one_call_and_batched_methods_get_a_throughput(serial_run):
    """analytic (a batched path of its own) and dls (none): every time is one solve call's, so a chunk's
    poses do not share one time; analytic's summary adds the throughput of two solve_many calls over the
    whole case, in one process and over every core, read back from its throughput file; dls has none."""
    from wbik.solvers.workers import usable_cores
    from wbik.study.results import chunk_path, load_method_rows, read_chunk, throughput_path

    summary = _summary(serial_run / "ur5_arm_pose" / "summary.csv")
    for label in ("analytic", "dls"):
        rows, line = load_method_rows(serial_run, "ur5_arm_pose", label, 4), summary[label]
        chunks = np.split(rows["time_s"], 4)  # 200 calls in 4 chunks: no chunk shares one time
        assert all(np.unique(chunk).size > 1 for chunk in chunks)
        if label == "dls":  # measured once, found without a batched path: an empty file
            assert read_chunk(throughput_path(serial_run, "ur5_arm_pose", label)) == {}
            assert "batch_success" not in rows and np.isnan(line["throughput_poses_per_s"])
            continue
        assert all("batch_success" not in read_chunk(chunk_path(serial_run, "ur5_arm_pose", label, chunk))
                   for chunk in range(4))  # the chunks hold per-call rows only; the pass has its own file
        for key in ("batch_share_s", "batch_cores_share_s"):
            assert np.all(np.isfinite(rows[key]) & (rows[key] > 0))
        assert line["throughput_poses_per_s"] == pytest.approx(200 / rows["batch_share_s"].sum())
        assert line["throughput_cores_poses_per_s"] == pytest.approx(200 / rows["batch_cores_share_s"].sum())
        assert line["throughput_cores"] == min(usable_cores(), 200)
        assert line["throughput_percent_solved"] == pytest.approx(100 * rows["batch_success"].mean())
        assert np.array_equal(rows["batch_success"], rows["batch_cores_success"])  # the same answers
        assert line["throughput_disagreements"] == np.sum(rows["batch_success"] != rows["success"])
    section = (serial_run / "report.md").read_text().split("### Throughput of batched methods")[1]
    assert ("| method | poses/s, one process | poses/s, every core | cores | % solved (solve_many) | "
            "disagree |") in section.split("### ")[0]
    assert "| dls |" not in section.split("### ")[0]


def test_a_batch_that_raises_leaves_no_throughput_and_the_rows_stand(rng):
    """A batched path that raises (here on every call, the untimed first call included): both calls'
    columns say so (unsolved, NaN time), and the summary has no throughput for it."""
    from wbik.study.chain_targets import batch_columns
    from wbik.study.statistics import throughput_figures

    class Raising:
        def solve_many(self, targets, q0s, workers=1):
            raise RuntimeError("broken batch")

    columns = batch_columns(Raising(), [None] * 5, np.zeros((5, 6)), 2)
    assert not columns["batch_success"].any() and not columns["batch_cores_success"].any()
    assert np.all(np.isnan(columns["batch_share_s"])) and np.all(np.isnan(columns["batch_cores_share_s"]))
    figures = throughput_figures({**columns, "success": np.ones(5, dtype=bool)})
    assert np.isnan(figures["throughput_poses_per_s"]) and np.isnan(figures["throughput_cores_poses_per_s"])
    assert figures["throughput_disagreements"] == 5


def test_rows_from_before_the_cores_column_still_summarise():
    """Chunk files written when the batch was timed per chunk in one process: one rate, no cores."""
    from wbik.study.statistics import throughput_figures

    old = {"batch_success": np.array([True, False]), "batch_share_s": np.array([0.1, 0.1]),
           "success": np.array([True, True])}
    figures = throughput_figures(old)
    assert figures["throughput_poses_per_s"] == pytest.approx(10.0)
    assert np.isnan(figures["throughput_cores_poses_per_s"]) and np.isnan(figures["throughput_cores"])
    assert figures["throughput_disagreements"] == 1


def test_mann_whitney_p_values_match_scipy_on_the_raw_rows(serial_run):
    import csv

    rows = read_raw_csv(serial_run / "ur5_arm_pose" / "raw.csv")
    with open(serial_run / "ur5_arm_pose" / "significance.csv", newline="") as handle:
        tests = list(csv.DictReader(handle))
    assert {t["axis"] for t in tests} >= {"x", "y", "z", "rot_x", "alpha", "beta", "gamma", "time"}
    assert {t["method"] for t in tests} == {"dls", "kdl"}
    base = rows["analytic"]
    for test in tests:
        assert test["baseline"] == "analytic"
        other, axis = rows[test["method"]], test["axis"]
        if axis == "time":
            expected = stats.mannwhitneyu(base["time_s"] * 1e3, other["time_s"] * 1e3)
        else:
            expected = stats.mannwhitneyu(np.abs(base[f"err_{axis}"][base["success"]]),
                                          np.abs(other[f"err_{axis}"][other["success"]]))
        assert float(test["p_value"]) == pytest.approx(expected.pvalue, rel=1e-12, abs=0)
        assert float(test["U"]) == expected.statistic


CLOCKS = ("time_s", "cpu_s", "reruns", "batch_share_s", "batch_cores_share_s")


def _answers(output: Path, case: str, chunks: int) -> dict[str, dict[str, np.ndarray]]:
    """{label: rows} of every method with all its ``chunks`` chunk files, less the clocks (time_s, cpu_s,
    reruns, the batch calls' shares): the answers a report's raw.csv shows, without drawing the report."""
    rows = {}
    for folder in sorted((output / case / "chunks").iterdir()):
        found = load_method_rows(output, case, folder.name, chunks)
        if found is not None:
            rows[folder.name] = {k: v for k, v in found.items() if k not in CLOCKS}
    return rows


def test_serial_and_parallel_runs_agree(serial_run, tmp_path):
    study_file = _write(tmp_path, STUDY)
    run_study(load_study(study_file), tmp_path / "out", jobs=2, backend="loky", progress=False, report=False,
              log=lambda message: None)
    for case in ("ur5_arm_pose", "arm3r_arm_position"):
        serial = _answers(serial_run, case, 4)  # 200 poses, 50 per chunk
        assert {"analytic", "dls"} <= set(serial)
        _same_rows(serial, _answers(tmp_path / "out", case, 4))


def test_a_different_study_in_the_same_folder_is_refused(serial_run, tmp_path):
    study_file = _write(tmp_path, STUDY.replace("seed: 11", "seed: 12"))
    assert main(["study", str(study_file), "-o", str(serial_run), "--no-progress"]) == 2


def test_adding_a_method_reuses_the_chunks_of_the_others(tmp_path):
    """Judged on the chunk files (the rows every report is made from): the runs after the first write
    no report, and the first one none of its figures (they would take most of the test's time)."""
    study_file = _write(tmp_path, STUDY.replace("poses: 200", "poses: 60"))
    output = tmp_path / "out"
    assert main(["study", str(study_file), "-o", str(output), "--methods", "analytic", "--no-progress",
                 "--backend", "sequential", "--no-figures"]) == 0
    chunk = output / "ur5_arm_pose" / "chunks" / "analytic" / "chunk_00000.npz"
    throughput = output / "ur5_arm_pose" / "chunks" / "analytic" / "throughput.npz"
    stamp, throughput_stamp = chunk.stat().st_mtime_ns, throughput.stat().st_mtime_ns
    assert set(read_raw_csv(output / "ur5_arm_pose" / "raw.csv")) == {"analytic"}
    run_study(load_study(study_file), output, backend="sequential", progress=False, report=False,
              log=lambda message: None)
    assert chunk.stat().st_mtime_ns == stamp and throughput.stat().st_mtime_ns == throughput_stamp
    chunks = 2  # 60 poses, 50 per chunk
    for label in ("dls", "kdl"):
        assert load_method_rows(output, "ur5_arm_pose", label, chunks) is not None, label
    changed = _write(tmp_path, STUDY.replace("poses: 200", "poses: 60").replace("max_iterations: 60",
                                                                                "max_iterations: 5"))
    dls_chunk = output / "ur5_arm_pose" / "chunks" / "dls" / "chunk_00000.npz"
    dls_stamp = dls_chunk.stat().st_mtime_ns
    run_study(load_study(changed), output, backend="sequential", progress=False, report=False,
              log=lambda message: None)
    assert chunk.stat().st_mtime_ns == stamp and dls_chunk.stat().st_mtime_ns != dls_stamp
    assert load_method_rows(output, "ur5_arm_pose", "dls", chunks)["iterations"].max() <= 5
    throughput.unlink()  # a pass lost (or killed before its file was written) is run again alone
    run_study(load_study(changed), output, backend="sequential", progress=False, report=False,
              log=lambda message: None)
    assert chunk.stat().st_mtime_ns == stamp and throughput.is_file()


# -- resume after a kill -------------------------------------------------------------------------
class SlowDLS(DampedLeastSquares):
    """DLS that sleeps 20 ms per pose, so a run can be killed half-way."""

    name = "slow_dls"

    def _solve(self, target, q0, deadline):
        time.sleep(0.02)
        return super()._solve(target, q0, deadline)


RESUME_STUDY = """
name: resume
robot: arm3r
chain: arm
target: position
poses: 100
chunk_size: 10
timeout_s: 1.0
methods: [slow_test_dls]
"""


def _run_child(study_file: str, output: str) -> None:
    run_study(load_study(study_file), Path(output), backend="sequential", progress=False, report=False,
              log=lambda message: None)


def test_a_killed_run_resumes_without_recomputing_finished_chunks(tmp_path):
    wbik.register("slow_test_dls", SlowDLS, "test only")
    study_file = _write(tmp_path, RESUME_STUDY, "resume.yaml")
    output = tmp_path / "out"
    chunks = output / "arm3r_arm_position" / "chunks" / "slow_test_dls"
    child = multiprocessing.get_context("fork").Process(target=_run_child,
                                                        args=(str(study_file), str(output)))
    child.start()
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and len(list(chunks.glob("chunk_*.npz"))) < 3:
        time.sleep(0.02)
    os.kill(child.pid, signal.SIGKILL)
    child.join()
    finished = {path.name: path.stat().st_mtime_ns for path in chunks.glob("chunk_*.npz")}
    assert 3 <= len(finished) < 10, "the child should have been killed half-way"

    run_study(load_study(study_file), output, backend="sequential", progress=False, report=False,
              log=lambda m: None)
    after = {path.name: path.stat().st_mtime_ns for path in chunks.glob("chunk_*.npz")}
    assert len(after) == 10
    assert all(after[name] == stamp for name, stamp in finished.items())  # not recomputed
    import json

    assert json.loads((output / "run.json").read_text())["computed_tasks"] == 10 - len(finished)
    rows = _answers(output, "arm3r_arm_position", 10)
    assert np.array_equal(rows["slow_test_dls"]["pose"], np.arange(100))

    fresh = tmp_path / "fresh"
    run_study(load_study(study_file), fresh, backend="sequential", progress=False, report=False,
              log=lambda m: None)
    _same_rows(rows, _answers(fresh, "arm3r_arm_position", 10))


def test_the_dask_backend_on_a_local_cluster_agrees_with_the_serial_run(serial_run, tmp_path):
    from dask.distributed import LocalCluster

    study_file = _write(tmp_path, STUDY)
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        assert main(["study", str(study_file), "-o", str(tmp_path / "out"), "--backend", "dask",
                     "--scheduler", cluster.scheduler_address, "--no-progress", "--no-figures"]) == 0
    import json

    assert json.loads((tmp_path / "out" / "run.json").read_text())["backend"] == "dask"
    for case in ("ur5_arm_pose", "arm3r_arm_position"):
        _same_rows(read_raw_csv(serial_run / case / "raw.csv"),
                   read_raw_csv(tmp_path / "out" / case / "raw.csv"))
