"""The modules declaring what wbik ships (robots, IK methods, case samplers, scenario kinds, study case
kinds, task entry types), imported when a registry first needs them."""

from __future__ import annotations

from types import ModuleType

from wbik.registry import add_source


def robots() -> tuple[ModuleType, ...]:
    import wbik.robot_packages as shipped

    return (shipped,)


def ik_methods() -> tuple[ModuleType, ...]:
    import wbik.apps.bioloid.thesis_legs as thesis_legs
    import wbik.apps.golem3.thesis_solvers as thesis_solvers
    import wbik.solvers.analytic.solver as analytic
    import wbik.solvers.bounded_lm as bounded_lm
    import wbik.solvers.dls as dls
    import wbik.solvers.eaik as eaik
    import wbik.solvers.ik_geo as ik_geo
    import wbik.solvers.kdl as kdl
    import wbik.solvers.mink as mink
    import wbik.solvers.newton as newton
    import wbik.solvers.pink as pink
    import wbik.solvers.placo as placo
    import wbik.solvers.qp as qp
    import wbik.solvers.tracik as tracik

    return (analytic, newton, dls, bounded_lm, qp, kdl, tracik, placo, pink, eaik, ik_geo, mink,
            thesis_solvers, thesis_legs)


def case_samplers() -> tuple[ModuleType, ...]:
    import wbik.apps.bioloid.wholebody_cases as bioloid
    import wbik.apps.golem3.wholebody_cases as golem3

    return (bioloid, golem3)


def scenario_kinds() -> tuple[ModuleType, ...]:
    import wbik.apps.bioloid.scenarios as bioloid
    import wbik.apps.golem3.scenarios as golem3
    import wbik.apps.pincher.scenarios as pincher
    import wbik.apps.riveting.scenarios as riveting
    import wbik.motion.scenarios as motion
    import wbik.motion.walking.scenario as walk
    import wbik.scenarios.wholebody as wholebody

    return (wholebody, motion, walk, bioloid, golem3, pincher, riveting)


def study_case_kinds() -> tuple[ModuleType, ...]:
    import wbik.study.chain_targets as chain_targets
    import wbik.study.near_limits as near_limits
    import wbik.study.near_singularities as near_singularities
    import wbik.study.paths as paths
    import wbik.study.protocols as protocols
    import wbik.study.reach_boundary as reach_boundary
    import wbik.study.target_sets as target_sets
    import wbik.study.unreachable as unreachable
    import wbik.study.wholebody as wholebody

    return (chain_targets, wholebody, target_sets, near_limits, near_singularities, reach_boundary,
            unreachable, paths, protocols)


def task_entry_types() -> tuple[ModuleType, ...]:
    import wbik.qp.task_entries as task_entries

    return (task_entries,)


SHIPPED = {"robot": robots, "IK method": ik_methods, "whole-body case sampler": case_samplers,
           "scenario kind": scenario_kinds, "study case kind": study_case_kinds,
           "task entry type": task_entry_types}


def install() -> None:
    """Add the shipped modules (``SHIPPED``: per registry, the function naming them) to the registries."""
    for what, source in SHIPPED.items():
        add_source(what, source)
