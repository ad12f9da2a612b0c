"""Running a study, resumably: tasks (case, method, chunk of ``chunk_size`` poses) in parallel (joblib or
Dask), each chunk written as it arrives; a changed method is recomputed alone (docs/guide/studies.md)."""

from __future__ import annotations

import contextlib
import os
import shutil
import signal
import sys
import threading
import time
import traceback
from pathlib import Path

import numpy as np

import wbik.study.results as store
from wbik.dependencies import DASK_LIBRARY
from wbik.errors import WbikError
from wbik.solvers.workers import usable_cores
from wbik.study.applicability import not_applicable
from wbik.study.blocks import budget_kind
from wbik.study.budget_curves import budget_path, budget_tasks
from wbik.study.case_kinds import ChunkTask, case_kind
from wbik.study.compare import TARGETS_RECORD, targets_record
from wbik.study.context import chunk_count
from wbik.study.cpu_watch import threads_of, workers_for
from wbik.study.ownership import FolderLock
from wbik.study.provenance import PROVENANCE, code_roots, provenance
from wbik.study.sampling import PoseSet
from wbik.study.spec import CaseSpec, MethodSpec, Study, StudyDefinitionError

BACKENDS = ("loky", "sequential", "dask")


def solve_chunk(task: ChunkTask) -> dict[str, np.ndarray]:
    """The rows of one chunk, solved by the task's case kind (in a worker, or here)."""
    task.kind.register_entries(task.registered)
    return task.kind.solve(task)


# -- preparing ---------------------------------------------------------------------------------
def default_output(study: Study) -> Path:
    return Path("runs") / study.name


def prepare_output(study: Study, output: Path, fresh: bool, lock: FolderLock) -> None:
    """Refuse to mix results of a different study unless ``fresh`` (which empties the folder we hold)."""
    record = output / "study.json"
    previous = store.read_json(record)
    if previous is not None and previous.get("fingerprint") != study.fingerprint() and not fresh:
        raise StudyDefinitionError(
            f"{output} holds results of a study with other cases, poses, seed, start, chunk size or "
            f"tolerances (fingerprint {previous.get('fingerprint')} != {study.fingerprint()}); pass "
            "--fresh to delete them, or --output to write elsewhere. (Adding, removing or changing "
            "methods is fine: only the changed methods are recomputed.)")
    if fresh:
        lock.clear()
    store.write_json(record, {"fingerprint": study.fingerprint(), "source": study.source,
                              "study": study.as_dict()})


def case_poses(study: Study, case: CaseSpec, output: Path) -> PoseSet:
    """The case's poses: read back if already sampled, else sampled by the case's kind and saved."""
    path = store.case_dir(output, case.name) / "poses.npz"
    if path.is_file():
        return PoseSet.load(path)
    poses = case_kind(case).sample(study, case)
    poses.save(path)  # (its folder made on the way)
    return poses


def probe(study: Study, case: CaseSpec, method: MethodSpec, poses: PoseSet) -> str | None:
    """Why ``method`` does not apply to ``case`` (None if it does), on its first pose: a WbikError that is
    no refusal stops the study, any other error is "could not start" (one broken method stops nothing)."""
    task = case_kind(case).task(study, case, method, poses, 0, 0, 1)
    try:
        return not_applicable(task)
    except WbikError as exc:  # the study file asks for something wrong: say so before any solving
        raise StudyDefinitionError(
            f"{study.source}: method {method.label!r} on case {case.name!r} cannot be built as written: "
            f"{exc}") from exc
    except Exception as exc:  # noqa: BLE001 - a broken method must not stop the other methods
        detail = "".join(traceback.format_exception_only(type(exc), exc)).strip()
        return f"could not start (a bug to report): {detail}"


def pending_tasks(study: Study, output: Path, log=print) -> tuple[list[ChunkTask], int, int]:
    """(tasks still to run, rows already done, rows in total), probing applicability on the way."""
    tasks: list[ChunkTask] = []
    done_rows = total_rows = 0
    for case in study.cases:
        poses = case_poses(study, case, output)
        not_applicable: dict[str, str] = {}
        applicable = []
        for method in study.methods:
            _forget_if_changed(study, case, method, output, log)
            if (reason := probe(study, case, method, poses)) is None:
                applicable.append(method)
            else:
                not_applicable[method.label] = reason
                log(f"  {case.name}: {method.label} not applicable: {reason}")
        store.write_json(store.case_dir(output, case.name) / "not_applicable.json", not_applicable)
        for chunk in range(chunk_count(study, case)):
            start = chunk * study.chunk_size
            stop = min(start + study.chunk_size, len(poses))
            for method in applicable:
                total_rows += stop - start
                if store.chunk_path(output, case.name, method.label, chunk).is_file():
                    done_rows += stop - start
                else:
                    tasks.append(case_kind(case).task(study, case, method, poses, chunk, start, stop))
    store.write_json(output / TARGETS_RECORD, targets_record(study, output))
    return tasks, done_rows, total_rows


def throughput_pass(study: Study, output: Path, log=print) -> int:
    """Each case's throughput pass (:meth:`CaseKind.throughput`), in this process once every chunk is
    done, so that no other work of the study shares the cores: for each applicable method with all its
    chunks and no throughput file yet, over the case's poses, on every usable core (a method without a
    batched path gets a file without columns, so that a resumed run does not ask again). Returns how many
    files it wrote."""
    cores, written = usable_cores(), 0
    for case in study.cases:
        kind, poses = case_kind(case), None
        not_applicable = store.read_json(store.case_dir(output, case.name) / "not_applicable.json", {}) or {}
        for method in study.methods:
            path = store.throughput_path(output, case.name, method.label)
            chunks = [store.chunk_path(output, case.name, method.label, chunk)
                      for chunk in range(chunk_count(study, case))]
            if method.label in not_applicable or path.is_file() or not all(p.is_file() for p in chunks):
                continue
            poses = case_poses(study, case, output) if poses is None else poses
            task = kind.task(study, case, method, poses, 0, 0, len(poses))
            columns = kind.throughput(task, cores)
            if columns is not None:
                if columns:
                    log(f"  {case.name}: {method.label} throughput, solve_many over {len(poses)} poses")
                store.write_chunk(path, columns)
                written += 1
    return written


def _forget_if_changed(study: Study, case: CaseSpec, method: MethodSpec, output: Path, log) -> None:
    """Delete a method's chunks computed under another definition of that method; record the current."""
    folder = store.case_dir(output, case.name) / "chunks" / method.label
    record = folder / "method.json"
    fingerprint = study.method_fingerprint(method)
    previous = store.read_json(record)
    if previous is not None and previous.get("fingerprint") != fingerprint:
        log(f"  {case.name}: {method.label} changed since its results were computed; recomputing it")
        shutil.rmtree(folder)
    kind, seconds = case_kind(case), study.timeout_of(method)
    timeout_s, options = kind.budget(method.method, seconds, method.options)
    store.write_json(record, {"fingerprint": fingerprint, "method": method.__dict__, "timeout_s": seconds,
                              "solver_timeout_s": timeout_s, "solver_options": options,
                              "budget": budget_kind(kind, method, seconds)})


# -- running -----------------------------------------------------------------------------------
def _execute(tasks: list[ChunkTask], jobs: int, backend: str, scheduler: str | None):
    """Yield (task, rows) as tasks finish, on the chosen backend."""
    if backend == "sequential" or (backend == "loky" and jobs == 1):
        for task in tasks:
            yield task, solve_chunk(task)
        return
    from joblib import Parallel, delayed, parallel_config

    def run(n_jobs: int):
        parallel = Parallel(n_jobs=n_jobs, return_as="generator_unordered", batch_size=1,
                            pre_dispatch="2*n_jobs")
        yield from parallel(delayed(_solve_with_task)(task) for task in tasks)

    if backend == "loky":
        with parallel_config(backend="loky", initializer=_exit_with_parent, initargs=(os.getpid(),)):
            yield from run(jobs)
        return
    try:
        from dask.distributed import Client, LocalCluster
    except ImportError as exc:
        raise DASK_LIBRARY.error("the study's dask backend", exc) from None
    cluster = None if scheduler else LocalCluster(n_workers=jobs, threads_per_worker=1, processes=True,
                                                  dashboard_address=None)
    client = Client(scheduler or cluster)
    try:
        with parallel_config(backend="dask"):
            yield from run(-1)
    finally:
        client.close()
        if cluster is not None:
            cluster.close()


def phases(tasks: list[ChunkTask], jobs: int, backend: str, cores: int | None = None
           ) -> list[tuple[int, list[ChunkTask]]]:
    """``tasks`` as (workers, tasks) groups, run one after the other, most workers first: with loky a
    method of k threads runs with :func:`workers_for` (k, ``jobs``) workers; other backends keep ``jobs``."""
    groups: dict[int, list[ChunkTask]] = {}
    for task in tasks:
        workers = workers_for(threads_of(task.method), jobs, cores) if backend == "loky" else jobs
        groups.setdefault(workers, []).append(task)
    return sorted(groups.items(), key=lambda item: -item[0])


def _load_average() -> list[float] | None:
    """The system's 1, 5 and 15 minute load averages (None where the OS has none)."""
    try:
        return [round(value, 2) for value in os.getloadavg()]
    except (AttributeError, OSError):
        return None


_WATCHDOG: list[threading.Thread] = []


def _exit_with_parent(parent: int | None = None) -> None:
    """In a worker process: a daemon thread that ends the process when its parent (the study's main
    process) dies, even by SIGKILL: a killed study leaves no worker computing for nobody."""
    if _WATCHDOG:
        return
    parent = os.getppid() if parent is None else parent

    def watch() -> None:
        while os.getppid() == parent:
            time.sleep(0.5)
        os._exit(1)

    thread = threading.Thread(target=watch, name="wbik-parent-watchdog", daemon=True)
    thread.start()
    _WATCHDOG.append(thread)


def _solve_with_task(task: ChunkTask) -> tuple[ChunkTask, dict]:
    _exit_with_parent()
    return task, solve_chunk(task)


def run_study(study: Study, output: Path | None = None, *, jobs: int = 2, backend: str = "loky",
              scheduler: str | None = None, fresh: bool = False, progress: bool = True,
              report: bool = True, log=None) -> Path:
    """Run (or resume) ``study`` into ``output`` and write the report; returns the output folder."""
    if backend not in BACKENDS:
        raise StudyDefinitionError(f"unknown backend {backend!r}; choose one of {', '.join(BACKENDS)}")
    if jobs < 1:
        raise StudyDefinitionError(f"--jobs must be at least 1, got {jobs}")
    log = log or (lambda message: print(message, file=sys.stderr))
    output = Path(output) if output is not None else default_output(study)
    with FolderLock(output) as lock:
        with _terminate_as_interrupt():
            _run_locked(study, output, lock, jobs=jobs, backend=backend, scheduler=scheduler, fresh=fresh,
                        progress=progress, log=log)
        if report:
            from wbik.study.report import write_report

            write_report(study, output)
    return output


@contextlib.contextmanager
def _terminate_as_interrupt():
    """SIGTERM and SIGINT (a shell starts background jobs with it ignored) raise KeyboardInterrupt in the
    main thread while the study runs, so joblib terminates its workers."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def interrupt(signum, frame):
        raise KeyboardInterrupt(f"signal {signum}")

    previous = {number: signal.signal(number, interrupt) for number in (signal.SIGTERM, signal.SIGINT)}
    try:
        yield
    finally:
        for number, handler in previous.items():
            signal.signal(number, handler)


def _run_locked(study: Study, output: Path, lock: FolderLock, *, jobs: int, backend: str,
                scheduler: str | None, fresh: bool, progress: bool, log) -> None:
    prepare_output(study, output, fresh, lock)
    log(f"study {study.name!r} -> {output}")
    tasks, done_rows, total_rows = pending_tasks(study, output, log)
    curve_tasks, curve_done, curve_total = budget_tasks(study, output, log)
    if done_rows or curve_done:
        log(f"resuming: {done_rows + curve_done} of {total_rows + curve_total} rows already computed")
    started = time.perf_counter()
    load_before = _load_average()
    workers: dict[str, int] = {}
    if tasks or curve_tasks:
        from tqdm import tqdm

        with tqdm(total=total_rows + curve_total, initial=done_rows + curve_done, unit="solve",
                  disable=not progress, desc=study.name, smoothing=0.05, dynamic_ncols=True) as bar:
            for group, path in ((tasks, store.chunk_path), (curve_tasks, budget_path)):
                for count, phase in phases(group, jobs, backend):
                    workers.update({task.method: count for task in phase})
                    for task, rows in _execute(phase, count, backend, scheduler):
                        store.write_chunk(path(output, task.case, task.label, task.chunk), rows)
                        bar.update(len(rows["pose"]))
    measured = throughput_pass(study, output, log)
    elapsed = time.perf_counter() - started
    if tasks or curve_tasks or measured or not (output / PROVENANCE).is_file():  # what made the rows there
        store.write_json(output / PROVENANCE, provenance(study, [__name__]))
    previous = store.read_json(output / "run.json", {}) or {}
    store.write_json(output / "run.json", {
        "jobs": jobs, "backend": backend, "computed_tasks": len(tasks), "seconds": elapsed,
        "budget_curve_tasks": len(curve_tasks), "cores": usable_cores(),
        "workers": workers or previous.get("workers", {}),
        "cpu_count": os.cpu_count(), "load_average_before": load_before,
        "load_average_after": _load_average(),
        "total_seconds": elapsed + float(previous.get("total_seconds", 0.0)) if tasks else
        float(previous.get("total_seconds", elapsed))})


def study_code_roots(study: Study) -> list[str]:
    """The modules the code fingerprint of ``study``'s rows starts from (:func:`code_roots`, from here)."""
    return code_roots(study, [__name__])
