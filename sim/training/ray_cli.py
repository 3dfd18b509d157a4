"""The command line's side of Ray: `--ray ADDRESS` for `pete-sim train` and `pete-sim eval`, and
`pete-sim sweep` (sim.training.sweep). Nothing here imports ray until a command runs with it."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from protocol.cli_conventions import add_no_progress, progress_wanted
from sim.errors import ConfigError

if TYPE_CHECKING:
    from sim.training.config import TrainConfig
    from sim.training.ray_backend import RayBackend

RAY_ADDRESS = (
    "host:port of the cluster's head (what `ray start --head` prints; port 6379 by default), "
    "ray://host:10001 (Ray Client, from a machine outside the cluster), auto (the cluster this "
    "machine joined with `ray start`) or local (a one-machine Ray started here)"
)


def add_ray_option(p: argparse.ArgumentParser, what: str) -> None:
    """--ray ADDRESS on a command; `what` says what runs on the cluster."""
    p.add_argument(
        "--ray",
        metavar="ADDRESS",
        default=None,
        help=f"{what}; ADDRESS is {RAY_ADDRESS}. Needs the ray extra (pip install -e .[ray]) "
        "and the same checkout installed on every node; sim/TRAINING.md says how to start a "
        "cluster",
    )


def ray_backend(address: str | None) -> RayBackend | None:
    """The backend for --ray ADDRESS, not yet connected (None without --ray); a missing ray
    extra is a ClusterError now, before any work starts."""
    if address is None:
        return None
    from sim.training.ray_backend import RayBackend, require_ray

    require_ray()
    return RayBackend(address)


def check_ray_training(cfg: TrainConfig, cpus: float | None) -> None:
    """--ray for training: the pybullet backend, whose rollout workers become actors of one CPU
    each, and an evaluation task needs one more while they wait. A cluster short of them would
    wait forever, so it is refused now (cpus None: not known yet, the rest is checked)."""
    if cfg.backend != "pybullet":
        raise ConfigError(
            f"--ray spreads the pybullet backend's rollout workers; the {cfg.backend} backend "
            "steps its matches in the training process"
        )
    workers = cfg.rollout.workers
    if workers < 1:
        raise ConfigError(
            "--ray runs the rollout workers as Ray actors, and this config steps its matches in "
            "the training process ([rollout] workers = 0): give --workers N"
        )
    evaluating = cfg.evaluation.every_steps > 0
    need = workers + (1 if evaluating else 0)
    if cpus is not None and cpus < need:
        extra = ", and its periodic evaluation one more" if evaluating else ""
        raise ConfigError(
            f"the Ray cluster has {cpus:.0f} CPU(s); {workers} rollout actor(s) need one "
            f"each{extra}: fewer --workers, or more nodes (ray start --address=HEAD on another "
            "machine)"
        )


SWEEP_DESCRIPTION = """\
A hyperparameter sweep with Ray Tune. Every combination of the --param grids (and --samples
draws of any distribution) is a trial: the config trained as `pete-sim train` trains it, with
the trial's values set. A trial reports the trainer's evaluation (the config's [evaluation]
opponent, matches and seed) at every periodic evaluation and once at its end; Tune runs the trials
side by side on the cluster (one trial holds max(1, rollout.workers) CPUs), and its ASHA
scheduler can stop weak ones early. Writes RUN/sweep.json (every trial's values, metric and run
folder), RUN/trials/<trial id>/ (each trial's run folder: checkpoints, policy) and RUN/tune/
(Tune's own records), and prints a table of the trials.

examples:
  pete-sim sweep --config tiny --param ppo.learning_rate=1e-3,5e-4 --param ppo.ent_coef=0,0.01
  pete-sim sweep --config capped --param ppo.learning_rate=loguniform:1e-4:3e-3 --samples 8 \\
      --param seed=1,2 --ray auto --scheduler asha --metric eval/win_rate
"""


def add_sweep_command(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "sweep",
        help="a hyperparameter sweep of a training config with Ray Tune",
        description=SWEEP_DESCRIPTION,
    )
    p.add_argument(
        "--config", required=True, help="a TOML file, or the name of one in sim/configs/"
    )
    p.add_argument(
        "--param",
        action="append",
        metavar="KEY=VALUES",
        help="a config key as the TOML file spells it (ppo.learning_rate, rollout.steps_per_env, "
        "env.reward.ring, seed) and its values: a comma-separated grid (1e-3,5e-4; TOML "
        'values: true, [32, 32], "planner"), uniform:LO:HI, loguniform:LO:HI or randint:LO:HI '
        "(drawn per trial), or one value (set in every trial); repeat for more keys",
    )
    p.add_argument(
        "--samples",
        type=int,
        default=1,
        help="Tune's num_samples: the grid runs this many times, distributions drawn anew each "
        "time (a grid repeats as it is: sweep seed=1,2 to repeat it on other seeds)",
    )
    p.add_argument(
        "--metric",
        default="eval/quality",
        help="what ranks the trials, a scalar the trainer reports at an evaluation: eval/quality "
        "(win rate + fill rate - 0.01 x median fill time, what best.pt is chosen by), "
        "eval/win_rate, eval/rings, eval/score_margin, eval/fill_rate",
    )
    p.add_argument("--mode", choices=("max", "min"), default="max", help="max or min the metric")
    p.add_argument(
        "--scheduler",
        choices=("fifo", "asha"),
        default="fifo",
        help="fifo: every trial runs to its end; asha: Tune's ASHA stops trials that trail the "
        "others at the periodic evaluations (set [evaluation] every_steps)",
    )
    p.add_argument("--steps", type=int, default=None, help="override total_steps in every trial")
    p.add_argument(
        "--max-concurrent",
        type=int,
        default=0,
        help="at most this many trials at once; 0: as many as the cluster has CPUs for",
    )
    p.add_argument(
        "--run-dir",
        type=Path,
        default=None,
        help="the sweep's folder (default: runs/sweep-<config name>)",
    )
    add_ray_option(p, "the cluster Tune runs the trials on (default: a Ray started here)")
    add_no_progress(p)
    p.set_defaults(func=cmd_sweep)


def cmd_sweep(args: argparse.Namespace) -> int:
    from sim.errors import ClusterError
    from sim.training.ray_backend import require_ray
    from sim.training.sweep import SweepOptions, parse_param, run_sweep

    try:
        require_ray("pete-sim sweep (Ray Tune runs its trials)")
        if not args.param:
            raise ConfigError("give at least one --param KEY=VALUES to sweep")
        options = SweepOptions(
            config=args.config,
            params=tuple(parse_param(t) for t in args.param),
            run_dir=args.run_dir or Path("runs") / f"sweep-{Path(args.config).stem}",
            samples=args.samples,
            metric=args.metric,
            mode=args.mode,
            scheduler=args.scheduler,
            steps=args.steps,
            max_concurrent=args.max_concurrent,
            verbose=1 if progress_wanted(args.no_progress) else 0,
        )
        result = run_sweep(options, args.ray)
    except (ConfigError, ClusterError) as e:
        print(f"pete-sim sweep: {e}", file=sys.stderr)
        return 2
    print(result.table())
    print(f"summary: {result.summary}")
    failed = sum(1 for r in result.rows if r.status != "done")
    if failed:
        print(f"pete-sim sweep: {failed} of {len(result.rows)} trials failed", file=sys.stderr)
    return 1 if failed else 0
