"""Computing time per 10 ms control tick of our dynamic walk: the pattern (preview controller step,
ZMP reference, swing and stance feet) plus the whole-body QP step, on the Bioloid and on Talos.

The walks are those of tasks/bioloid_walk_dynamic.yaml and tasks/talos_walk.yaml (their first, the
straight one; settings read from the files). Each round plans and tracks the walk once (its reference
fed forward from the plan before the first tick, as the files run it) and times every tick with
``time.perf_counter``; the figures are the per-round median, 95th percentile
and maximum over the ticks, given as ranges over the rounds, and the share of ticks over 1 ms. PlaCo's
own per-tick cost on the same footsteps (its WalkTasks IK, 3 iterations a tick, at our timing; its
plan is made once, offline) is timed the same way for comparison.

This machine is shared (2 cores): under load a few per cent of the ticks wait for another process
(milliseconds, by the wall clock); the thread's CPU time per tick (``time.thread_time``) is also given,
which such waits do not change. The first tick of each kind of support builds its QP (about 2 ms,
once per walk).

Run: .venv/bin/python benchmarks/walking.py [--rounds 5]
"""

from __future__ import annotations

import argparse
import os
import platform
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
BUDGET_S = 1e-3
"""The goal: pattern + whole-body step within 1 ms per 10 ms tick."""


def spec_of(name: str) -> dict:
    from wbik.scenarios import load_scenario

    return load_scenario(ROOT / "tasks" / name)


def setup(name: str):
    """(robot, q0, command, timing, options for walk(), feet, trunk) of a task file's first walk."""
    from wbik.motion.walking.footsteps import StepCommand
    from wbik.motion.walking.scenario import _spec_objects
    from wbik.motion.walking.timeline import Timing
    from wbik.scenarios.kinds import robot_of, start_of
    from wbik.scenarios.schema import validate

    spec = validate(spec_of(name), name)
    robot = robot_of(spec)
    feet, _, preview, settings = _spec_objects(spec, robot)
    item = spec["walks"][0]
    command = StepCommand(item["steps"], item["length"], item["lateral"], item["turn_deg"], item["first"])
    timing = Timing(**{**spec["timing"], **(item["timing"] or {})})
    options = {"dt": spec["dt"], "clearance": spec["clearance"], "feet": feet, "preview": preview,
               "com_height": spec["com_height"], "settings": settings,
               "zmp_forward": spec["zmp_forward"], "backend": spec["backend"]}
    return robot, start_of(spec, robot), command, timing, options, feet, settings


def ranges(values: list[float]) -> str:
    low, high = min(values), max(values)
    return f"{low * 1e3:.3f}-{high * 1e3:.3f} ms"


def measure(name: str, rounds: int) -> dict:
    from wbik.motion.walking.placo_pattern import placo_walk
    from wbik.motion.walking.tracking import trunk_frame, walk

    robot, q0, command, timing, options, feet, settings = setup(name)
    figures = {"pattern_median": [], "step_median": [], "pattern_p95": [], "step_p95": [], "median": [],
               "p95": [], "max": [], "over": [], "cpu_median": [], "cpu_p95": [], "cpu_max": [],
               "cpu_over": [],
               "placo_median": [], "placo_p95": [], "ticks": 0}
    for _ in range(rounds):
        motion = walk(robot, q0, command, timing, **options)
        ticks = motion.tick_time_s[1:]
        figures["pattern_median"].append(float(np.median(motion.pattern.tick_time_s[1:])))
        figures["step_median"].append(float(np.median(motion.step_time_s[1:])))
        figures["pattern_p95"].append(float(np.percentile(motion.pattern.tick_time_s[1:], 95)))
        figures["step_p95"].append(float(np.percentile(motion.step_time_s[1:], 95)))
        figures["median"].append(float(np.median(ticks)))
        figures["p95"].append(float(np.percentile(ticks, 95)))
        figures["max"].append(float(ticks.max()))
        figures["over"].append(float(np.mean(ticks > BUDGET_S)))
        cpu = motion.tick_cpu_s[1:]
        figures["cpu_median"].append(float(np.median(cpu)))
        figures["cpu_p95"].append(float(np.percentile(cpu, 95)))
        figures["cpu_max"].append(float(cpu.max()))
        figures["cpu_over"].append(float(np.mean(cpu > BUDGET_S)))
        figures["ticks"] = len(ticks)
        placo = placo_walk(robot, q0, motion.pattern.footsteps, feet, trunk_frame(robot, settings), "ours",
                           timing, options["clearance"], 0.005, options["preview"].horizon_s, options["dt"])
        figures["placo_median"].append(float(np.median(placo.tick_time_s[1:])))
        figures["placo_p95"].append(float(np.percentile(placo.tick_time_s[1:], 95)))
    figures["collision_pairs"] = motion.collision_pairs
    figures["nv"] = robot.model.nv
    return figures


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--rounds", type=int, default=5)
    args = parser.parse_args()
    print(f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
          f"Python {platform.python_version()}; {args.rounds} rounds")
    for name in ("bioloid_walk_dynamic.yaml", "talos_walk.yaml"):
        f = measure(name, args.rounds)
        print(f"\n{name} (nv = {f['nv']}, {f['ticks']} ticks, {f['collision_pairs']} leg collision pairs)")
        print(f"  pattern per tick: median               {ranges(f['pattern_median'])}, "
              f"p95 {ranges(f['pattern_p95'])}")
        print(f"  whole-body QP step per tick: median    {ranges(f['step_median'])}, "
              f"p95 {ranges(f['step_p95'])}")
        print(f"  pattern + step per tick: median        {ranges(f['median'])}, p95 {ranges(f['p95'])}, "
              f"max {ranges(f['max'])}")
        print(f"  ticks over {BUDGET_S * 1e3:g} ms: {min(f['over']) * 100:.1f}-{max(f['over']) * 100:.1f} %")
        print(f"  the same in CPU time: median {ranges(f['cpu_median'])}, p95 {ranges(f['cpu_p95'])}, "
              f"max {ranges(f['cpu_max'])}; over {BUDGET_S * 1e3:g} ms: "
              f"{min(f['cpu_over']) * 100:.1f}-{max(f['cpu_over']) * 100:.1f} %")
        print(f"  PlaCo's IK per tick (WalkTasks, 3 iterations): median {ranges(f['placo_median'])}, "
              f"p95 {ranges(f['placo_p95'])}")


if __name__ == "__main__":
    main()
