"""`ptwl task`: the onboard state machines, headless, as fast as the CPU allows.

ptwl task list                                  the tasks with a state machine
ptwl task run TASK [--seed N] [--json]          one trial: success, end, sim time, figures
ptwl task bench TASK [--seeds N]                N trials: success rate and the paper's means
"""

import argparse
import itertools
import json
import os
import statistics
import sys
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

from tqdm import tqdm

from robot_sim.limits import GRIPPER_CLOSE_S
from robot_sim.machines.engine import settings_model
from robot_sim.machines.library import read_machine
from robot_sim.machines.spec import MachineSpec
from robot_sim.policies import POLICIES, TaskRun, policy_for, run_onboard
from robot_sim.policies.paper_tables import beside_paper
from robot_sim.policies.run import paper_rows
from robot_sim.scenes import get_scene
from robot_sim.scenes.grasp import PNEUMATIC_CLOSE_S, check_close_time
from robot_sim.warm import warm_up


def cmd_list(_: argparse.Namespace) -> int:
    for name, policy in POLICIES.items():
        print(f"{name:16s} {policy.summary}\n{'':16s} scene: {get_scene(name).description}")
        for setting, schema in policy.settings_model.model_json_schema()["properties"].items():
            print(f"{'':16s} --set {setting}=  (default {schema['default']}) {schema.get('description', '')}")
    return 0


def machine_and_task(args: argparse.Namespace) -> tuple[MachineSpec | None, str]:
    """`--machine FILE` (read and checked: a ConfigError names the file, state and field) and
    the task whose scene it runs on (its own `task`, or the positional one)."""
    if args.machine is None:
        if args.task is None:
            raise ValueError("give a task, or --machine FILE")
        return None, str(args.task)
    spec = read_machine(Path(args.machine))
    task = args.task or spec.task
    if task is None or task not in POLICIES:
        raise ValueError(
            f"--machine {args.machine}: name its scene (`task` in the file, or the task argument)"
        )
    return spec, task


def overrides(task: str, pairs: list[str], spec: MachineSpec | None = None) -> dict[str, object]:
    """`--set NAME=VALUE` (VALUE as JSON: 0, 12.5, true), checked by the task's settings."""
    out: dict[str, object] = {}
    for pair in pairs:
        name, _, value = pair.partition("=")
        try:
            out[name] = json.loads(value)
        except json.JSONDecodeError:
            raise ValueError(f"--set {pair}: the value must be JSON (a number, true or false)") from None
    # Checked by the machine's own settings: a ValidationError names the setting.
    if spec is not None:
        settings_model(spec).model_validate(out)
    else:
        policy_for(task, out)
    return out


def run_line(run: TaskRun) -> str:
    m = run.as_dict()
    ptwl = ", ".join(f"{k} {v}" for k, v in m["ptwl"].items())
    return (
        f"{run.task} seed {run.seed}: {'SUCCESS' if run.success else 'no success'} "
        f"(progress {run.progress:.4g} {run.unit}); machine ended {run.end}: {run.why}\n"
        f"  sim time {run.sim_time_s:.2f} s, run time {m['run_time_s']:.2f} s, "
        f"max force {m['max_force_n']:.1f} N, max torque {m['max_torque_nm']:.2f} N m, "
        f"{m['behaviors']} behaviors: RWE {m['rwe']}, Dither {m['dither']}, PTWL ({ptwl})"
        + (f"; gripper {m['gripper']}" if m["gripper"] else "")
    )


def cmd_run(args: argparse.Namespace) -> int:
    spec, task = machine_and_task(args)
    run = run_onboard(
        task,
        args.seed,
        overrides=overrides(task, args.set, spec),
        gripper_close_s=args.gripper_close_s,
        machine=spec,
    )
    if args.json:
        print(json.dumps(run.as_dict()))
    else:
        print(run_line(run))
        for step in run.steps:
            r = step.report
            print(f"  {step.index:2d} {r.behavior:7s} -> {r.exit.value:13s} {step.why}")
    return 0 if run.success else 1


def bench_table(task: str, runs: list[TaskRun]) -> str:
    """The paper's Tables 1-3 layout: success, then the mean of each figure over the trials."""
    rows = paper_rows([r.as_dict() for r in runs], [r.success for r in runs])
    progress = [r.progress for r in runs]
    rows.append(
        (f"Progress [{runs[0].unit}] (min / mean)", f"{min(progress):.4g} / {statistics.fmean(progress):.4g}")
    )
    for figure in runs[0].figures:  # the machine's own (a tool exchange's cycles)
        values = [r.figures[figure] for r in runs]
        rows.append(
            (
                f"{figure.capitalize()}, by the machine (min / mean)",
                f"{min(values):g} / {statistics.fmean(values):g}",
            )
        )
    lines = [f"| {task} | mean over trials |", "|---|---|"]
    return "\n".join(lines + [f"| {name} | {value} |" for name, value in rows])


def cmd_bench(args: argparse.Namespace) -> int:
    """Seeds 0..N-1 on every core (each trial is its own simulation: the same numbers whatever
    the number of workers); a progress bar on a terminal."""
    seeds = range(args.seeds)
    spec, task = machine_and_task(args)
    check_close_time(task, get_scene(task).gripper, args.gripper_close_s)  # before any worker starts
    warm_up()  # compiled here once, into the cache every worker then loads (robot_sim/warm.py)
    with ProcessPoolExecutor(max_workers=args.workers) as pool:
        trials = pool.map(
            run_onboard,
            itertools.repeat(task),
            seeds,
            itertools.repeat(None),
            itertools.repeat(overrides(task, args.set, spec)),
            itertools.repeat(args.gripper_close_s),
            itertools.repeat(spec),
        )
        runs = list(tqdm(trials, total=len(seeds), desc=task, unit="trial", file=sys.stderr))
    print(bench_table(task, runs))
    ours = paper_rows([r.as_dict() for r in runs], [r.success for r in runs])
    heading = "ours" if args.gripper_close_s is None else f"ours, gripper_close_s {args.gripper_close_s:g}"
    if beside := beside_paper(task, ours, heading):
        print("\n".join(["", *beside]))
    return 0


def add_task_parser(sub: "argparse._SubParsersAction[argparse.ArgumentParser]") -> None:
    task = sub.add_parser("task", help="the tasks' onboard state machines, headless")
    verbs = task.add_subparsers(dest="verb", required=True)
    verbs.add_parser("list", help="tasks with a state machine").set_defaults(func=cmd_list)
    run = verbs.add_parser("run", help="one trial, as fast as the CPU allows")
    run.add_argument("task", nargs="?", choices=list(POLICIES), help="its built-in machine (or --machine)")
    run.add_argument("--machine", help="a machine file (TOML, README: Machines); its task names the scene")
    run.add_argument("--seed", type=int, default=None, help="the scene's misalignments (default: nominal)")
    run.add_argument("--json", action="store_true", help="one JSON object instead of text")
    run.add_argument("--set", action="append", default=[], metavar="NAME=VALUE", help="override a setting")
    add_scene_options(run)
    run.set_defaults(func=cmd_run)
    bench = verbs.add_parser("bench", help="seeds 0..N-1: success rate and the paper's table of means")
    bench.add_argument("task", nargs="?", choices=list(POLICIES), help="its built-in machine (or --machine)")
    bench.add_argument("--machine", help="a machine file (TOML, README: Machines); its task names the scene")
    bench.add_argument("--seeds", type=int, default=100)
    bench.add_argument("--workers", type=int, default=os.cpu_count(), help="processes (default: every core)")
    bench.add_argument("--set", action="append", default=[], metavar="NAME=VALUE", help="override a setting")
    add_scene_options(bench)
    bench.set_defaults(func=cmd_bench)


def add_scene_options(parser: argparse.ArgumentParser) -> None:
    low, high = GRIPPER_CLOSE_S
    parser.add_argument(
        "--gripper-close-s",
        type=float,
        default=None,
        metavar="S",
        help=f"the gripper's closing time constant, [{low}, {high}] s (default: the tool bay's own, 0.01; "
        f"{PNEUMATIC_CLOSE_S}: the paper's pneumatic gripper and its closing impact)",
    )
