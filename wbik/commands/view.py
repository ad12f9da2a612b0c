"""Show ROBOT (built-in name or URDF path) at a configuration, or play a TASKFILE's motion (tasks/*.yaml).
Without --html/--screenshot a local meshcat server starts and prints its URL; Ctrl-C stops it."""

from __future__ import annotations

import argparse
import contextlib
import sys
import time
from pathlib import Path

import numpy as np

from wbik.data import SCENARIO_SUFFIXES
from wbik.errors import InvalidTargetError, UnknownRobotError, UsageError

HELP = "show a robot or play a scenario in meshcat (browser), or export it"
EPILOG = ("Examples: wbik view ur5 --q 0 -1.57 1.57 -1.57 -1.57 0 --frames;  wbik view pincher --html "
          "pincher.html;  wbik view bioloid --com --screenshot b.png")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("robot", metavar="ROBOT|TASKFILE",
                        help="built-in robot (see 'wbik robots'), a .urdf path, or a scenario .yaml")
    parser.add_argument("--q", type=float, nargs="+",
                        help="joint values: the chain's with --chain, else the full configuration "
                             "(or the only chain's)")
    parser.add_argument("--chain", help="chain that --q, --target and --frames refer to")
    parser.add_argument("--deg", action="store_true", help="revolute values (and target RPY) in degrees")
    parser.add_argument("--frames", action="store_true", help="draw the chain's base, joint and tip frames")
    parser.add_argument("--target", type=float, nargs="+", metavar="V",
                        help="IK target in the chain's base frame: X Y Z [ROLL PITCH YAW] (m, rad)")
    parser.add_argument("--com", action="store_true", help="draw the CoM and the support polygon (feet)")
    parser.add_argument("--style", choices=("auto", "visual", "stick"), default="auto",
                        help="URDF visuals or a stick model (auto: visuals when the robot has them)")
    parser.add_argument("--html", type=Path, metavar="PATH",
                        help="write a self-contained HTML page (opens offline) instead of serving")
    parser.add_argument("--screenshot", type=Path, metavar="PNG",
                        help="render a PNG with headless Chromium instead of serving")
    parser.add_argument("--open", action="store_true", help="open the served page in a web browser")
    parser.add_argument("--seconds", type=float, default=None,
                        help="serve this long then stop (default: until Ctrl-C)")


def build_viewer(args: argparse.Namespace, server: bool):
    """The Viewer for ``args``: a robot scene, or a scenario's animation."""
    import pinocchio as pin

    from wbik.models import load
    from wbik.viz.viewer import Viewer, animation_viewer

    source = Path(args.robot)
    if source.suffix.lower() in SCENARIO_SUFFIXES:
        from wbik.scenarios import scenario_animation

        return animation_viewer(scenario_animation(source)[1], server, args.style, f"wbik: {source.stem}")
    try:
        robot = load(args.robot)
    except UnknownRobotError as exc:
        raise UnknownRobotError(args.robot, exc.known, hint="Pass a built-in name ('wbik robots' lists "
                                "them), the path of a .urdf file, or a scenario file (.yaml)") from None
    viewer = Viewer(robot, server=server, style=args.style)
    chain = robot.chain(args.chain) if args.chain else None
    if args.q is not None:
        q = np.asarray(args.q, dtype=float)
        if args.deg and (chain is not None or q.size != robot.model.nq):  # one chain's values
            values_chain = chain or robot.chain()
            q = values_chain.check_q(q)
            q = np.where(values_chain.is_prismatic, q, np.radians(q))
        elif args.deg:  # the full configuration's 1-DOF bounded revolute joints
            revolute = [joint.idx_q for joint in robot.model.joints[1:] if joint.nq == 1 and
                        joint.shortname().startswith("JointModelR") and "Unbounded" not in joint.shortname()]
            q[revolute] = np.radians(q[revolute])
        viewer.show(q, chain)
    if args.frames:
        viewer.show_frames(chain)
    if args.target is not None:
        values = np.asarray(args.target, dtype=float)
        if values.size not in (3, 6):
            raise InvalidTargetError(f"--target takes X Y Z or X Y Z ROLL PITCH YAW; got {values.size}")
        angles = np.radians(values[3:]) if args.deg else values[3:]
        target = pin.SE3(pin.rpy.rpyToMatrix(*angles), values[:3]) if values.size == 6 else values[:3]
        viewer.show_target(target, chain or robot.chain())
    if args.com:
        support = viewer.show_com_and_polygon()
        state = "inside" if support.inside else "OUTSIDE"
        print(f"CoM {np.array2string(support.com, precision=4)} m; its ground projection is {state} the "
              f"support polygon (margin {support.margin * 1000:.1f} mm)")
    return viewer


def run(args: argparse.Namespace) -> int:
    offline = args.html is not None or args.screenshot is not None
    if args.open and offline:
        raise UsageError("--open serves the scene; it does not go with --html/--screenshot")
    for option, path in (("--html", args.html), ("--screenshot", args.screenshot)):
        if path is not None and path.is_dir():
            raise UsageError(f"{option} {str(path)!r} is a folder; it names the file to write")
    if args.seconds is not None and not args.seconds >= 0:
        raise UsageError(f"--seconds must be >= 0, got {args.seconds}")
    viewer = build_viewer(args, server=not offline)
    if offline:
        if args.html is not None:
            viewer.export_html(args.html)
            print(f"wrote {args.html} (self-contained: open it in any browser, no server needed)")
        if args.screenshot is not None:
            from wbik.viz.browser import find_chromium, render

            find_chromium()  # fail early, with the install hint, before exporting
            page = args.html or viewer.export_html(args.screenshot.with_suffix(".html"))
            result = render(page, args.screenshot)
            print(f"wrote {args.screenshot}" + (f" (page errors: {result.errors})" if result.errors else ""))
        return 0
    with viewer, contextlib.suppress(KeyboardInterrupt):  # Ctrl-C stops the server
        print(f"meshcat viewer for {viewer.title.removeprefix('wbik: ')}: {viewer.url}")
        if args.open:
            import webbrowser

            if not webbrowser.open(viewer.url, new=2):
                print("no web browser found on this machine: open the URL above in a browser that can "
                      "reach this machine, or write a file with --html scene.html", file=sys.stderr)
        if args.seconds is None:
            print("serving; press Ctrl-C to stop", flush=True)
            while True:
                time.sleep(3600)
        time.sleep(args.seconds)
    return 0
