"""`pete-sim`: the digital twin of the field, training and evaluation. Commands arrive with the
parts they drive."""

from __future__ import annotations

import argparse
import importlib.metadata
import shutil
import signal
import sys
import tomllib
from pathlib import Path
from typing import TYPE_CHECKING, Any

from protocol.cli_conventions import add_no_progress, make_parser, progress_wanted

if TYPE_CHECKING:
    from sim.evaluate import PlayerSpec

DESCRIPTION = """\
The simulator side of Pac-Man Pete: a PyBullet twin of the Tipping Point field, Gymnasium and
PettingZoo environments, PPO self-play training and evaluation.

  pete-sim versions        the simulation stack this environment has installed
  pete-sim view            a PNG of a seeded field and a GIF of a scripted match
  pete-sim train           PPO self-play from a TOML config (sim/configs/), --resume to go on;
                           --ray ADDRESS: its rollouts and evaluation on a Ray cluster
  pete-sim sweep           a hyperparameter sweep of a training config with Ray Tune
  pete-sim export          a checkpoint to policy.onnx + policy.json (onnxruntime only)
  pete-sim eval            seeded matches of a policy against another: rings, score, wins
                           (--ray ADDRESS: as tasks on a Ray cluster)
  pete-sim play            one match as a top-down GIF with a score overlay + reward plots
  pete-sim match           the whole robot stack (Brain core, wire, Jetson daemon) on the
                           simulated field, or --stack sim: summary, replay GIF, plots
  pete-sim dataset         labelled camera frames as a perception dataset folder

Players for eval/play: a policy.onnx, a checkpoint .pt, a run folder, original:PATH (the
original team's ONNX), planner, planner-nearest, planner-collector (never parks), scripted,
random, idle (and none as opponent).
"""

_STACK = ("pacman-pete", "pybullet", "gymnasium", "pettingzoo", "torch", "numpy", "onnxruntime")


def _cmd_versions(_: argparse.Namespace) -> int:
    missing = 0
    for name in _STACK:
        try:
            version = importlib.metadata.version(name)
        except importlib.metadata.PackageNotFoundError:
            version = "not installed (pip install 'pacman-pete[sim]')"
            missing += 1
        print(f"{name:<14} {version}")
    return 1 if missing else 0


def _cmd_view(args: argparse.Namespace) -> int:
    # Imported here: `pete-sim versions` must work where PyBullet is missing.
    from sim.view import write_view

    try:
        written = write_view(
            seed=args.seed,
            out=args.out,
            fidelity=args.fidelity,
            stride=args.stride,
            size=args.size,
            seconds=args.seconds,
            gif=not args.no_gif,
            camera=not args.no_camera,
            world=args.world,
        )
    except (ValueError, OSError) as e:
        print(f"pete-sim view: {e}", file=sys.stderr)
        return 2
    for path in written:
        print(path)
    return 0


def _interrupt(signum: int, frame: object) -> None:
    raise KeyboardInterrupt


# What `train` writes into a run folder: a folder holding any of them holds a run.
RUN_FILES = ("config.json", "run.json", "history.jsonl", "policy.onnx", "policy.json")
RUN_FOLDERS = ("checkpoints", "tb", "best")


def run_entries(run_dir: Path) -> list[Path]:
    """The files and folders of an earlier training run in `run_dir`."""
    return [run_dir / n for n in RUN_FILES + RUN_FOLDERS if (run_dir / n).exists()]


def _clear_run(run_dir: Path) -> None:
    """--force: remove what an earlier run wrote (only that: other files in the folder stay)."""
    for path in run_entries(run_dir):
        if path.is_dir() and not path.is_symlink():
            shutil.rmtree(path)
        else:
            path.unlink()


def _cmd_train(args: argparse.Namespace) -> int:
    from contextlib import nullcontext
    from dataclasses import replace

    from sim.errors import ClusterError, ConfigError, WorkerError
    from sim.training.config import load_config
    from sim.training.ray_cli import check_ray_training, ray_backend
    from sim.training.trainer import train

    try:
        cfg = load_config(args.config)
        if args.steps is not None:
            cfg = replace(cfg, total_steps=args.steps)
        if args.seed is not None:
            cfg = replace(cfg, seed=args.seed)
        if args.workers is not None:
            cfg = replace(cfg, rollout=replace(cfg.rollout, workers=args.workers))
        cluster = ray_backend(args.ray)
        if args.backend is not None:
            cfg = replace(cfg, backend=args.backend)
        cfg.on_backend()  # a config the backend cannot run fails here, before the run folder
        if cluster is not None:
            check_ray_training(cfg, None)
        run_dir = args.run_dir or Path("runs") / cfg.name
        if args.resume and args.force:
            raise ConfigError(
                "--resume continues the run in the folder, --force replaces it: not both"
            )
        if not args.resume and run_entries(run_dir):
            if not args.force:
                names = ", ".join(p.name for p in run_entries(run_dir))
                raise ConfigError(
                    f"{run_dir} already holds a training run ({names}): --resume continues it, "
                    "--force starts a new one there (deleting those), or choose another --run-dir"
                )
            _clear_run(run_dir)
        # SIGTERM stops like Ctrl-C: a checkpoint and an export, then exit.
        signal.signal(signal.SIGTERM, _interrupt)
        progress = progress_wanted(args.no_progress)
        with cluster or nullcontext():
            if cluster is not None:  # the rollout workers as actors, evaluations as tasks
                check_ray_training(cfg, cluster.cpus())
            result = train(
                cfg,
                run_dir,
                resume=args.resume,
                progress=progress,
                launcher=None if cluster is None else cluster.launch,
                runner=None if cluster is None else cluster.play,
            )
            if cluster is not None:
                print(cluster.describe())
    except (ConfigError, ValueError, FileNotFoundError, WorkerError, ClusterError) as e:
        print(f"pete-sim train: {e}", file=sys.stderr)
        return 2
    stopped = " (interrupted: --resume goes on)" if result.interrupted else ""
    print(f"{result.steps} steps in {result.wall_s:.0f} s, {result.episodes} matches{stopped}")
    print(f"run folder: {result.run_dir}")
    if result.policy is not None:
        print(f"policy: {result.policy}")
    return 0


def _cmd_export(args: argparse.Namespace) -> int:
    from sim.errors import ConfigError
    from sim.match import make_config
    from sim.training.checkpoint import agent_from_checkpoint, load_checkpoint
    from sim.training.export import export_policy

    try:
        state = load_checkpoint(args.checkpoint)
        agent, spec, cfg = agent_from_checkpoint(state)
        env = make_config(cfg.env_config(), observation=spec)
        training: dict[str, Any] = {
            "config": cfg.name, "seed": cfg.seed, "steps": int(state["step"])
        }  # fmt: skip
        if "wall_s" in state:
            training["wall_s"] = float(state["wall_s"])
        if args.skill:
            settings = skill_overrides(args.skill)
            if env.skills is None:
                raise ValueError("--skill: this checkpoint's policy has no skills")
            env = make_config(env, skills=settings)
            assert env.skills is not None
            env.skills.check(spec)
            training["skills_set"] = settings  # set at export, not in training
        onnx_path, meta = export_policy(agent, spec, env, args.out, training)
    except (ValueError, FileNotFoundError, KeyError, ConfigError) as e:
        print(f"pete-sim export: {e}", file=sys.stderr)
        return 2
    print(onnx_path)
    print(meta)
    return 0


# The skill controller's settings `pete-sim export --skill` may change: how the options are
# driven, not which options there are (the network's outputs) nor the robot's size and speeds
# (taken from the robot's config).
EXPORT_SKILLS = (
    "route_through_next", "commit_goal_s", "share_platform", "platform_lanes_m", "platform_past_m",
    "platform_speed_mps", "split_with_partner", "split_margin_m", "keep_clear_s",
    "keep_clear_m", "climb_at_s", "release_dragged_s", "partner_room_m", "lookahead_m",
    "turn_gain",
    "turn_in_place_rad", "stuck_window_s", "stuck_distance_m", "backoff_s",
)  # fmt: skip


def skill_overrides(words: list[str]) -> dict[str, Any]:
    """--skill KEY=VALUE words as a dict of SkillConfig settings, VALUE read as TOML (true,
    0.3, [-0.3, 0.4]); a key that is not a controller setting is a ValueError naming them."""
    out: dict[str, Any] = {}
    for word in words:
        key, sep, text = word.partition("=")
        key = key.strip()
        if not sep or key not in EXPORT_SKILLS:
            raise ValueError(
                f"--skill {word!r}: expected KEY=VALUE, KEY one of {', '.join(EXPORT_SKILLS)}"
            )
        try:
            out[key] = tomllib.loads(f"v = {text.strip()}")["v"]
        except tomllib.TOMLDecodeError as e:
            raise ValueError(f"--skill {word!r}: {text!r} is not a TOML value ({e})") from None
    return out


def _opponent(word: str) -> PlayerSpec | None:
    from sim.evaluate import load_player

    return None if word == "none" else load_player(word)


def _side(word: str) -> tuple[PlayerSpec, ...] | None:
    """A side of a match from NAME or NAME,NAME (one per robot), or none."""
    from sim.evaluate import load_side

    return None if word == "none" else load_side(word)


def _cmd_eval(args: argparse.Namespace) -> int:
    import json
    from contextlib import nullcontext

    from sim.errors import ClusterError, EvalError, OriginalPolicyError
    from sim.evaluate import evaluate, load_side
    from sim.training.ray_cli import ray_backend

    try:
        cluster = ray_backend(args.ray)
        a = load_side(args.policy)
        b = _side(args.opponent)
        from tqdm import tqdm

        with (
            cluster or nullcontext(),
            tqdm(
                total=args.matches,
                unit="match",
                desc="pete-sim eval",
                disable=not progress_wanted(args.no_progress),
                dynamic_ncols=True,
            ) as bar,
        ):
            summary = evaluate(
                a,
                b,
                args.matches,
                args.seed,
                scenario=args.scenario,
                fidelity=args.fidelity,
                progress=lambda done, total: bar.update(done - bar.n),
                world=args.world,
                runner=None if cluster is None else cluster.play,
            )
    except (EvalError, OriginalPolicyError, ClusterError) as e:
        print(f"pete-sim eval: {e}", file=sys.stderr)
        return 2
    print(summary.table())
    if args.json is not None:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps(summary.as_dict(), indent=1) + "\n")
        print(f"wrote {args.json}")
    return 0


def _cmd_play(args: argparse.Namespace) -> int:
    from sim.errors import EvalError, OriginalPolicyError
    from sim.evaluate import load_side, side_label
    from sim.replay import write_replay

    try:
        a = load_side(args.policy)
        b = _side(args.opponent)
        written, record = write_replay(
            a,
            b,
            args.out,
            seed=args.seed,
            scenario=args.scenario,
            fidelity=args.fidelity,
            a_alliance=args.side,
            stride=args.stride,
            size=args.size,
            seconds=args.seconds,
            plot=args.plot,
            world=args.world,
        )
    except (EvalError, OriginalPolicyError, OSError) as e:
        print(f"pete-sim play: {e}", file=sys.stderr)
        return 2
    for path in written:
        print(path)
    print(
        f"{side_label(a)} ({args.side}): {record.rings[0]} rings, {record.score[0]:.0f} points; "
        f"{side_label(b) if b else 'nobody'}: {record.rings[1]} rings, "
        f"{record.score[1]:.0f} points"
    )
    return 0


WORLD_HELP = (
    "the match (sim.config.WORLD_PRESETS): ring_race (the default: the original team's 1v1 "
    'ring race), tipping_point_1v1 (the whole VEX AI game, one 24" robot an alliance) or '
    'tipping_point_2v2 (the whole game: a 24" and a 15" robot an alliance, 15 s isolation + '
    "105 s interaction); the whole game adds its score by element and the fouls to the summary"
)


def _add_world(p: argparse.ArgumentParser) -> None:
    from sim.config import WORLD_PRESETS  # dataclasses only: --help stays light

    p.add_argument("--world", choices=tuple(WORLD_PRESETS), default=None, help=WORLD_HELP)


def _add_match_options(p: argparse.ArgumentParser) -> None:
    p.add_argument("--seed", type=int, default=0, help="first match seed")
    p.add_argument(
        "--scenario",
        choices=("capped", "uncapped"),
        default="capped",
        help="capped: the report's 10-ring task; uncapped: every ring counts",
    )
    p.add_argument(
        "--fidelity", choices=("training", "high"), default="training", help="physics fidelity"
    )


def _add_match(sub: argparse._SubParsersAction) -> None:
    # The full-stack match lives in sim/fullstack (sim/fullstack/README.md); the whole game's
    # sim-stack match in sim/game_match.py, picked with --world.
    from sim.fullstack.cli import add_match_command

    add_match_command(sub)
    p = sub.choices["match"]
    p.description = (p.description or "") + (
        " --world tipping_point_1v1 / tipping_point_2v2 plays the whole game. With --stack sim "
        "every robot is driven by a player (--policy for red, --opponent for blue: a name for "
        "all of an alliance's robots, or NAME,NAME one per robot); with --stack full the red "
        '24" is the full stack (brain_host, the wire, the daemon running the scripted '
        "alliance), its partner --partner and blue --opponent players in the twin. "
        "summary.txt/json break both alliances' scores down by element with the fouls; "
        "replay.gif shows the platforms' tilt, the goals' owners and their rings. Examples: "
        "pete-sim match --stack sim --world tipping_point_2v2 --policy alliance --opponent "
        "planner-collector,scripted; pete-sim match --world tipping_point_2v2 --opponent alliance"
    )
    _add_world(p)
    p.set_defaults(func=_cmd_match, ring_race_match=p.get_default("func"))


# Options of the full stack that the whole game's sim-stack match does not take.
_FULL_STACK_ONLY = ("fault", "faults", "realtime", "daemon", "record", "dashboard")


def _cmd_match(args: argparse.Namespace) -> int:
    if args.world in (None, "ring_race"):
        args.world = None
        return args.ring_race_match(args)
    if args.stack != "sim":
        # The full stack drives the red 24" (the daemon runs the scripted alliance); its
        # partner and the blue alliance are players in the twin.
        return args.ring_race_match(args)
    given = [f"--{n}" for n in _FULL_STACK_ONLY if getattr(args, n, None)]
    if given:
        print(
            f"pete-sim match: {', '.join(given)} belong(s) to the full stack; the whole game's "
            "sim-stack match does not take them",
            file=sys.stderr,
        )
        return 2
    return _cmd_game_match(args)


def _cmd_game_match(args: argparse.Namespace) -> int:
    import json

    from sim.errors import ConfigError, EvalError, OriginalPolicyError
    from sim.game_match import GameMatchOptions, run_game_match

    out = args.out or Path("runs") / f"match-sim-{args.world}-seed{args.seed}"
    options = GameMatchOptions(
        world=args.world,
        out=out,
        seed=args.seed,
        red=str(args.policy) if args.policy is not None else "scripted",
        blue=args.opponent,
        scenario=args.scenario,
        seconds=args.seconds,
        gif=not args.no_gif,
        gif_every_s=args.gif_every,
        gif_size=args.gif_size,
    )
    progress = None if args.quiet or args.json else (lambda m: print(m, flush=True))
    try:
        result = run_game_match(options, progress)
    except (EvalError, OriginalPolicyError, ConfigError, OSError) as e:
        print(f"pete-sim match: {e}", file=sys.stderr)
        return 2
    if args.json:
        print(json.dumps(result.as_dict(), indent=1))
    else:
        print(result.table())
        print(f"run folder: {out}")
        if "gif" in result.files:
            print(f"replay: {result.files['gif']}")
    return 0


def _add_dataset(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "dataset",
        help="render labelled camera frames as a perception dataset folder",
        description="Render N camera frames from seeded random robot poses, ring layouts, "
        "lighting and colours, and write images/, YOLO labels/, depth/ (uint16 mm), truth/ "
        "(ring positions in the robot frame), dataset.json and frames.jsonl: the folder "
        "`pete-jetson detector train --data` and `detector eval --images` read.",
    )
    p.add_argument("--frames", type=int, required=True, help="how many frames")
    p.add_argument("--out", type=Path, required=True, help="an empty or new folder")
    p.add_argument("--seed", type=int, default=0, help="frame k is drawn from (seed, k)")
    p.add_argument("--width", type=int, default=640, help="image width, pixels")
    p.add_argument("--height", type=int, default=480, help="image height, pixels")
    p.add_argument("--robots", default="15in,24in", help="observing robots, comma-separated")
    p.add_argument("--no-augment", action="store_true", help="no blur or noise on the images")
    p.add_argument(
        "--viewpoint",
        default="robot",
        help="robot: each robot's own camera; spectator: photos of the field from "
        "0.8-1.9 m up outside its walls, where far rings are a few pixels wide (training data "
        "for a detector that must also work on people's photos)",
    )
    add_no_progress(p)
    p.set_defaults(func=_cmd_dataset)


def _cmd_dataset(args: argparse.Namespace) -> int:
    from jetson.errors import DatasetError
    from sim.dataset import DatasetConfig, write_dataset
    from sim.errors import ConfigError

    try:
        robots = tuple(n.strip() for n in args.robots.split(",") if n.strip())
        cfg = DatasetConfig(
            frames=args.frames,
            seed=args.seed,
            width=args.width,
            height=args.height,
            robots=robots,
            augment=not args.no_augment,
            viewpoint=args.viewpoint,
        )
        labels = write_dataset(cfg, args.out, progress=progress_wanted(args.no_progress))
    except (ConfigError, OSError, DatasetError) as e:
        print(f"pete-sim dataset: {e}", file=sys.stderr)
        return 2
    print(f"wrote {cfg.frames} frames, {labels} labelled rings to {args.out}")
    return 0


def build_parser() -> argparse.ArgumentParser:
    from sim.training.ray_cli import add_ray_option, add_sweep_command  # no ray: --help is light

    parser = make_parser("pete-sim", DESCRIPTION)
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    p = sub.add_parser("versions", help="print the installed simulation stack's versions")
    p.set_defaults(func=_cmd_versions)

    p = sub.add_parser(
        "view",
        help="write start.png and match.gif (scripted robots) for a seed",
        description="Render the field for a seed (start.png, camera.png) and a scripted match "
        "between two greedy ring-chasers (match.gif).",
    )
    p.add_argument("--seed", type=int, default=0, help="match seed")
    p.add_argument("--out", type=Path, default=Path("sim-view"), help="output folder")
    p.add_argument(
        "--fidelity", choices=("training", "high"), default="training", help="physics fidelity"
    )
    p.add_argument("--stride", type=int, default=4, help="control steps per GIF frame")
    p.add_argument("--size", type=int, default=480, help="image width in pixels")
    p.add_argument("--seconds", type=float, default=None, help="stop the match early")
    p.add_argument("--no-gif", action="store_true", help="only the start images")
    p.add_argument("--no-camera", action="store_true", help="skip the camera render")
    _add_world(p)
    p.set_defaults(func=_cmd_view)

    p = sub.add_parser(
        "train",
        help="train a policy with PPO self-play from a TOML config",
        description="Train with PPO self-play. Writes config.json, run.json, TensorBoard logs "
        "(tb/), checkpoints/ and the exported policy.onnx + policy.json to the run folder. A "
        "folder that already holds a run is refused unless --resume (go on with it) or --force "
        "(delete it and start again) says what to do.",
    )
    p.add_argument(
        "--config", required=True, help="a TOML file, or the name of one in sim/configs/"
    )
    p.add_argument(
        "--run-dir", type=Path, default=None, help="the run folder (default: runs/<config name>)"
    )
    p.add_argument("--resume", action="store_true", help="continue from checkpoints/latest.pt")
    p.add_argument(
        "--force",
        action="store_true",
        help="start a new run in a folder that holds one, deleting its checkpoints, logs and "
        "policy",
    )
    p.add_argument("--steps", type=int, default=None, help="override total_steps")
    p.add_argument("--seed", type=int, default=None, help="override the config's seed")
    p.add_argument(
        "--backend",
        choices=("pybullet", "fast"),
        default=None,
        help="where the matches run (overrides the config's backend): pybullet, the twin's "
        "training fidelity on worker processes; fast, thousands of matches at once in one "
        "process (numpy and compiled loops, sim/fast/; [fast] envs and steps_per_env size it). "
        "A config the fast backend cannot run yet is refused with what it lacks",
    )
    p.add_argument(
        "--workers",
        type=int,
        default=None,
        help="override [rollout] workers: how many rollout workers (processes here, Ray actors "
        "with --ray) each step envs_per_worker matches",
    )
    add_ray_option(
        p,
        "run the rollout workers as Ray actors (one CPU each, spread over the cluster's nodes "
        "by Ray) and the periodic evaluation's matches as Ray tasks; the learner, the update "
        "and the self-play pool stay in this process",
    )
    add_no_progress(p)
    p.set_defaults(func=_cmd_train)
    add_sweep_command(sub)

    p = sub.add_parser("export", help="export a checkpoint to policy.onnx + policy.json")
    p.add_argument("--checkpoint", type=Path, required=True, help="a .pt checkpoint of a run")
    p.add_argument("--out", type=Path, required=True, help="an .onnx path or a folder")
    p.add_argument(
        "--skill", action="append", default=[], metavar="KEY=VALUE",
        help="set a skill controller setting in policy.json (how the options are driven, e.g. "
        "share_platform=true); repeatable; recorded as the policy's training.skills_set",
    )  # fmt: skip
    p.set_defaults(func=_cmd_export)

    p = sub.add_parser(
        "eval",
        help="evaluate a policy against an opponent on seeded matches",
        description="Deterministic seeded matches, sides swapped per seed: mean and 95 %% "
        "interval of rings, score and pins, win rate by match score, fill time of 10 rings. "
        "With --world tipping_point_1v1 or tipping_point_2v2, the whole game: also each "
        "alliance's score by element (rings on high branches, low branches and bases, goals in "
        "the home zone and elevated, robots elevated, autonomous bonus and win point) and its "
        "fouls by kind. Example: pete-sim eval --world tipping_point_2v2 --policy planner,scripted "
        "--opponent scripted --matches 4",
    )
    p.add_argument(
        "--policy",
        required=True,
        help="player A: one player for every robot of its alliance, or NAME,NAME one per robot "
        'in the world\'s order (tipping_point_2v2: the 24" robot, then the 15")',
    )
    p.add_argument(
        "--opponent", default="planner", help="player B (NAME or NAME,NAME as for A), or none"
    )
    p.add_argument("--matches", type=int, default=20, help="matches to play")
    _add_world(p)
    _add_match_options(p)
    p.add_argument("--json", type=Path, default=None, help="also write the summary as JSON")
    add_ray_option(
        p,
        "play the matches as Ray tasks (a seed's pair of matches each) spread over a cluster: "
        "the same records as here, sooner on many CPUs; player files must be at the same path "
        "on every node",
    )
    add_no_progress(p)
    p.set_defaults(func=_cmd_eval)

    p = sub.add_parser(
        "play",
        help="replay one match as a GIF with a score overlay, and plot its rewards",
        description="One seeded match, top-down, with the score in the caption; beside the GIF "
        "a PNG of every reward component, the rings and the score over time.",
    )
    p.add_argument("--policy", required=True, help="player A (NAME or NAME,NAME one per robot)")
    p.add_argument("--opponent", default="planner", help="player B (as A), or none")
    p.add_argument("--out", type=Path, default=Path("match.gif"), help="the GIF to write")
    _add_world(p)
    p.add_argument(
        "--plot", type=Path, default=None, help="the reward plot (default: <out>_rewards.png)"
    )
    p.add_argument("--side", choices=("red", "blue"), default="red", help="A's alliance")
    p.add_argument("--stride", type=int, default=3, help="control steps per GIF frame")
    p.add_argument("--size", type=int, default=480, help="image width in pixels")
    p.add_argument("--seconds", type=float, default=None, help="stop the match early")
    _add_match_options(p)
    p.set_defaults(func=_cmd_play)
    _add_match(sub)
    _add_dataset(sub)
    return parser


# What only the sim extra installs (import names): a command that misses one says so.
_SIM_EXTRA = {"pybullet", "gymnasium", "pettingzoo", "torch", "tensorboard", "tqdm", "matplotlib",
              "PIL", "onnx"}  # fmt: skip


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    if sys.version_info < (3, 11) and args.func is not _cmd_versions:
        print(
            f"pete-sim: the simulator needs Python 3.11 or newer (this is "
            f"{sys.version_info.major}.{sys.version_info.minor}); the Jetson side (pete-jetson) "
            "runs on 3.10",
            file=sys.stderr,
        )
        return 2
    try:
        return args.func(args)
    except ModuleNotFoundError as exc:
        if (exc.name or "").split(".")[0] not in _SIM_EXTRA:
            raise
        print(
            f"pete-sim: {exc.name} is not installed: the simulator needs the sim extra "
            "(pip install '.[sim]' in a checkout, or pip install 'pacman-pete[sim]')",
            file=sys.stderr,
        )
        return 2


if __name__ == "__main__":
    sys.exit(main())
