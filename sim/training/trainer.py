"""The training loop: self-play rollouts, PPO updates, logs, checkpoints, export.

    result = train(load_config("default"), Path("runs/default"))
    result = train(cfg, Path("runs/default"), resume=True)        # from checkpoints/latest.pt

A run folder holds:
    config.json       the resolved TrainConfig (every default spelled out)
    run.json          seed, versions, command line, start times (one entry per start/resume)
    history.jsonl     one line of scalars per iteration (what TensorBoard shows, for plots)
    tb/               TensorBoard logs: reward components, rings, score, win rate, ELO, losses,
                      entropy, steps/s, evaluation results
    checkpoints/      step_<N>.pt (the last keep_checkpoints), latest.pt, best.pt (evaluation)
    policy.onnx, policy.json          the final policy, exported for onnxruntime
    best/policy.onnx, best/policy.json the best evaluated policy, when evaluation is on

One iteration: every slot plays steps_per_env control steps (the learner samples its action, the
opponent is the current self-play snapshot or a fixed player); rewards are scaled by the running
return std; GAE; ppo_update; then the observation normaliser takes in the rollout's observations
(after the update, so the rollout's log-probabilities stay exact for the update that uses them).
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import platform
import statistics
import sys
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from datetime import UTC, datetime
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import torch

from jetson.autonomy.skills import SkillConfig
from jetson.autonomy.spec import ObservationSpec
from sim.fast.matches import FastMatches
from sim.match import MatchCore
from sim.ppo import Agent, Batch, RewardScaler, compute_gae, ppo_update
from sim.training.checkpoint import build_agent, load_checkpoint, save_checkpoint
from sim.training.config import TrainConfig
from sim.training.export import export_policy, versions
from sim.training.rollout import EpisodeStats, Launcher, VecMatches, advice_size
from sim.training.selfplay import OpponentPool

if TYPE_CHECKING:
    from sim.evaluate import SeriesRunner

POOL = "pool"


@dataclass
class Progress:
    """What a callback sees after every iteration."""

    step: int
    iteration: int
    wall_s: float  # training time so far, evaluation and callbacks excluded
    agent: Agent
    spec: ObservationSpec
    episodes: list[EpisodeStats]  # finished this iteration
    stats: dict[str, float]


Callback = Callable[[Progress], bool]  # return True to stop training


@dataclass
class TrainResult:
    run_dir: Path
    steps: int
    wall_s: float
    episodes: int
    policy: Path | None
    history: list[dict[str, float]] = field(default_factory=list)
    interrupted: bool = False


def observation_spec(cfg: TrainConfig) -> ObservationSpec:
    env = cfg.env_config()
    if env.observation is not None and not env.observation.needs_prior:
        return env.observation
    core = MatchCore(env)  # the world fixes the default spec and a memory's prior
    try:
        return core.spec
    finally:
        core.close()


@torch.no_grad()
def opponent_action(net: Agent, obs: torch.Tensor, generator: torch.Generator) -> torch.Tensor:
    """Agent.act's action alone, the same draw from `generator`: a frozen opponent never uses
    the log-probability and the value that act works out too (they cost half of it)."""
    dist = net.distribution(obs)
    noise = torch.randn(dist.mean.shape, generator=generator)
    return dist.mean + dist.stddev * noise


def _weights(agent: Agent) -> dict[str, torch.Tensor]:
    return {k: v.detach().clone() for k, v in agent.state_dict().items()}


def _mean(values: list[float]) -> float:
    return statistics.fmean(values) if values else math.nan


def episode_summary(episodes: list[EpisodeStats]) -> dict[str, float]:
    """Scalars for TensorBoard from matches that finished."""
    if not episodes:
        return {}
    out: dict[str, float] = {
        "episode/reward": _mean([e.reward for e in episodes]),
        "episode/length": _mean([float(e.length) for e in episodes]),
        "match/rings": _mean([float(e.rings) for e in episodes]),
        "match/score": _mean([e.score for e in episodes]),
        "match/score_margin": _mean([e.score - e.opponent_score for e in episodes]),
        "match/pins": _mean([float(e.pins) for e in episodes]),
        "match/partner_collisions": _mean([float(e.partner_collisions) for e in episodes]),
        "match/fill_rate": _mean([float(e.fill_time_s is not None) for e in episodes]),
    }
    fills = [e.fill_time_s for e in episodes if e.fill_time_s is not None]
    if fills:
        out["match/fill_time_s"] = _mean(fills)
    for name in episodes[0].components:
        out[f"reward/{name}"] = _mean([e.components[name] for e in episodes])
    for kind in sorted({e.kind for e in episodes}):
        results = [e.result for e in episodes if e.kind == kind and e.result is not None]
        if results:
            out[f"match/win_rate_{kind}"] = _mean([float(r == 1.0) for r in results])
    return out


class _Run:
    """State of one training run (so train() reads as the loop it is)."""

    def __init__(self, cfg: TrainConfig, run_dir: Path, resume: bool) -> None:
        self.cfg = cfg
        self.run_dir = run_dir
        self.ckpt_dir = run_dir / "checkpoints"
        self.spec = observation_spec(cfg)
        self.env = replace(cfg.env_config(), observation=self.spec)
        for phase in cfg.phases:  # a curriculum may change the game, never the observation
            later = observation_spec(cfg.at_step(phase["from_step"]))
            if later.fingerprint() != self.spec.fingerprint():
                raise ValueError(f"phase from step {phase['from_step']} changes the observation")
        torch.manual_seed(cfg.seed)
        self.gen = torch.Generator().manual_seed(cfg.seed)
        self.agent = build_agent(cfg, self.spec)
        self.optimizer = torch.optim.Adam(
            self.agent.parameters(), lr=cfg.ppo.learning_rate, eps=cfg.ppo.adam_eps
        )
        n = cfg.rollout.n_envs
        self.scaler = RewardScaler(n, cfg.ppo.gamma, cfg.ppo.reward_clip, cfg.ppo.norm_reward)
        self.pool = OpponentPool(cfg.selfplay, cfg.seed)
        self.step = 0
        self.iteration = 0
        self.episodes = 0
        self.wall_s = 0.0
        self.best_quality = -math.inf
        self.starts = 0
        if resume:
            self._load(self.ckpt_dir / "latest.pt")
        else:
            self.pool.start(0, _weights(self.agent))
        self.kinds = cfg.opponent_slots()
        self.opponents: dict[int, Agent] = {}

    def enter_phase(self, step: int) -> TrainConfig:
        """The config in force at `step`: the env and opponent kinds it plays."""
        current = self.cfg.at_step(step)
        self.env = replace(current.env_config(), observation=self.spec)
        self.kinds = current.opponent_slots()
        return current

    # --- checkpoints ------------------------------------------------------------------------

    def state(self) -> dict[str, Any]:
        return {
            "config": self.cfg.to_dict(),
            "spec": self.spec.to_dict(),
            "agent": self.agent.state_dict(),
            "obs_rms": self.agent.obs_norm.rms.state_dict(),
            "optimizer": self.optimizer.state_dict(),
            "reward_scaler": self.scaler.state_dict(),
            "pool": self.pool.state_dict(),
            "step": self.step,
            "iteration": self.iteration,
            "episodes": self.episodes,
            "wall_s": self.wall_s,
            "best_quality": self.best_quality,
            "starts": self.starts,
            "torch_rng": self.gen.get_state(),
        }

    def _load(self, path: Path) -> None:
        state = load_checkpoint(path)
        if ObservationSpec.from_dict(state["spec"]).fingerprint() != self.spec.fingerprint():
            raise ValueError(f"{path}: its observation spec differs from the config's")
        self.agent.load_state_dict(state["agent"])
        self.agent.obs_norm.rms.load_state_dict(state["obs_rms"])
        self.optimizer.load_state_dict(state["optimizer"])
        self.scaler.load_state_dict(state["reward_scaler"])
        self.pool.load_state_dict(state["pool"])
        self.step = int(state["step"])
        self.iteration = int(state["iteration"])
        self.episodes = int(state["episodes"])
        self.wall_s = float(state["wall_s"])
        self.best_quality = float(state.get("best_quality", -math.inf))
        self.starts = int(state.get("starts", 0))
        self.gen.set_state(state["torch_rng"])

    def checkpoint(self) -> Path:
        path = save_checkpoint(self.ckpt_dir / f"step_{self.step:09d}.pt", self.state())
        latest = self.ckpt_dir / "latest.pt"
        save_checkpoint(latest, self.state())
        old = sorted(self.ckpt_dir.glob("step_*.pt"))[: -self.cfg.keep_checkpoints]
        for p in old:
            p.unlink()
        return path

    # --- opponents --------------------------------------------------------------------------

    def opponent_net(self, snapshot_id: int) -> Agent:
        if snapshot_id not in self.opponents:
            net = build_agent(self.cfg, self.spec)
            net.load_state_dict(self.pool.get(snapshot_id).weights)
            net.eval()
            self.opponents[snapshot_id] = net
        return self.opponents[snapshot_id]

    def slot_kinds(self, tag: int) -> list[tuple[str, int]]:
        return [("policy", tag) if k == POOL else (k, -1) for k in self.kinds]


def _write_run_info(run_dir: Path, cfg: TrainConfig, spec: ObservationSpec, resumed: bool) -> None:
    (run_dir / "config.json").write_text(json.dumps(cfg.to_dict(), indent=1) + "\n")
    info_path = run_dir / "run.json"
    info: dict[str, Any] = {"starts": []}
    if info_path.is_file():
        with contextlib.suppress(json.JSONDecodeError):
            info = json.loads(info_path.read_text())
    info.update(
        {
            "name": cfg.name,
            "seed": cfg.seed,
            "observation": spec.to_dict(),
            "observation_fingerprint": spec.fingerprint(),
        }
    )
    info.setdefault("starts", []).append(
        {
            "time": datetime.now(UTC).isoformat(timespec="seconds"),
            "resumed": resumed,
            "command": sys.argv,
            "versions": versions(),
            "python": platform.python_version(),
            "machine": f"{platform.machine()}, {os.cpu_count()} cores, {platform.platform()}",
        }
    )
    info_path.write_text(json.dumps(info, indent=1) + "\n")


def evaluate_agent(
    agent: Agent,
    spec: ObservationSpec,
    opponent: str,
    matches: int,
    seed: int,
    skills: SkillConfig | None = None,
    runner: SeriesRunner | None = None,
) -> dict[str, float]:
    """Deterministic matches of the current agent (capped scenario); the scalars to log.
    runner: where the matches are played (sim.evaluate.evaluate; default: here)."""
    from sim.evaluate import PlayerSpec, evaluate, load_player
    from sim.players import PolicyPlayer

    @torch.no_grad()
    def act(obs: np.ndarray) -> np.ndarray:
        return agent.deterministic(torch.as_tensor(obs, dtype=torch.float32)[None])[0].numpy()

    ours = PlayerSpec("ours", lambda: PolicyPlayer(act, "ours", skills), spec)
    summary = evaluate(ours, load_player(opponent), matches, seed, "capped", runner=runner)
    a, b = summary.side(0), summary.side(1)
    return {
        "eval/fill_rate": a["fill_rate"],
        "eval/fill_median_s": a["fill_median_s"],
        "eval/opponent_fill_median_s": b["fill_median_s"],
        "eval/rings": a["rings"].mean,
        "eval/score": a["score"].mean,
        "eval/score_margin": a["score"].mean - b["score"].mean,
        "eval/win_rate": summary.win_rate,
    }


def quality(ev: dict[str, float]) -> float:
    """How evaluation ranks checkpoints: wins first, then filling the 10 rings, then speed."""
    fill = ev["eval/fill_median_s"]
    return (
        ev["eval/win_rate"] + ev["eval/fill_rate"] - 0.01 * (fill if math.isfinite(fill) else 105)
    )


def train(
    cfg: TrainConfig,
    run_dir: str | Path,
    resume: bool = False,
    progress: bool = True,
    callback: Callback | None = None,
    export: bool = True,
    launcher: Launcher | None = None,
    runner: SeriesRunner | None = None,
) -> TrainResult:
    """Train `cfg` into `run_dir` (see the module docstring).

    launcher: where the rollout workers run (sim.training.rollout.VecMatches; default: processes
    on this machine); runner: where the periodic evaluation's matches run (sim.evaluate.evaluate;
    default: here). sim.training.ray_backend.RayBackend gives both for a Ray cluster.
    """
    from torch.utils.tensorboard import SummaryWriter
    from tqdm import tqdm

    cfg = cfg.on_backend()
    run_dir = Path(run_dir)
    if resume and not (run_dir / "checkpoints" / "latest.pt").is_file():
        raise FileNotFoundError(f"--resume: no {run_dir / 'checkpoints' / 'latest.pt'}")
    run_dir.mkdir(parents=True, exist_ok=True)
    run = _Run(cfg, run_dir, resume)
    run.starts += 1
    _write_run_info(run_dir, cfg, run.spec, resume)
    p, r = cfg.ppo, cfg.rollout
    n, steps_per_env = r.n_envs, r.steps_per_env
    size = run.spec.size
    action_size = run.env.action_size
    writer = SummaryWriter(str(run_dir / "tb"))
    phase = cfg.phase_index(run.step)
    phase_cfg = run.enter_phase(run.step)

    def open_matches() -> VecMatches | FastMatches:
        # A resumed run (or a new phase) draws new matches: the seed stream moves on.
        if cfg.backend == "fast":
            return FastMatches(
                run.env,
                phase_cfg.rollout,
                seed=cfg.seed * 1_000 + run.starts + 100 * phase,
                teacher=cfg.imitation.teacher,
            )
        return VecMatches(
            run.env,
            phase_cfg.rollout,
            seed=cfg.seed * 1_000 + run.starts + 100 * phase,
            teacher=cfg.imitation.teacher,
            launcher=launcher,
        )

    vec = open_matches()
    threads = torch.get_num_threads()
    torch.set_num_threads(1)
    history: list[dict[str, float]] = []
    recent: deque[EpisodeStats] = deque(maxlen=64)
    bar = tqdm(
        total=cfg.total_steps,
        initial=min(run.step, cfg.total_steps),
        unit="step",
        disable=not progress,
        dynamic_ncols=True,
        smoothing=0.1,
    )
    last_checkpoint = run.step
    last_eval = run.step
    interrupted = False
    try:
        assert run.pool.current is not None
        current = run.pool.current.id
        active = [("policy", current) if k == POOL else (k, -1) for k in run.kinds]
        vec.set_kinds(active)
        pending = list(active)
        first = vec.reset()
        next_obs = first.learner_obs
        opp_obs = first.opponent_obs
        obs_buf = np.zeros((steps_per_env, n, size), np.float32)
        act_buf = np.zeros((steps_per_env, n, action_size), np.float32)
        logp_buf = np.zeros((steps_per_env, n), np.float32)
        rew_buf = np.zeros((steps_per_env, n), np.float32)
        done_buf = np.zeros((steps_per_env, n), bool)
        val_buf = np.zeros((steps_per_env, n), np.float32)
        n_advice = advice_size(run.env)
        advice_buf = np.full((steps_per_env, n, n_advice), np.nan, np.float32)
        advice = first.advice
        deciding = first.deciding
        deciding_buf = np.ones((steps_per_env, n), bool)
        uncapped = first.uncapped
        uncapped_buf = np.zeros((steps_per_env, n), bool)
        while run.step < cfg.total_steps:
            if cfg.phase_index(run.step) != phase:
                vec.close()
                phase = cfg.phase_index(run.step)
                phase_cfg = run.enter_phase(run.step)
                writer.add_text("phase", json.dumps(cfg.phases[phase - 1]), run.step)
                vec = open_matches()
                assert run.pool.current is not None
                active = [
                    ("policy", run.pool.current.id) if k == POOL else (k, -1) for k in run.kinds
                ]
                vec.set_kinds(active)
                pending = list(active)
                first = vec.reset()
                next_obs, opp_obs = first.learner_obs, first.opponent_obs
                advice, deciding, uncapped = first.advice, first.deciding, first.uncapped
                run.scaler.ret[:] = 0.0
            t0 = time.perf_counter()
            if p.anneal_lr:
                frac = max(0.0, 1.0 - run.step / cfg.total_steps)
                for group in run.optimizer.param_groups:
                    group["lr"] = p.learning_rate * frac
            finished: list[EpisodeStats] = []
            for t in range(steps_per_env):
                obs_t = torch.from_numpy(next_obs)
                action, logp, value = run.agent.act(obs_t, run.gen)
                opp_actions = np.zeros((n, action_size), np.float32)
                for tag in sorted({tag for kind, tag in active if kind == "policy"}):
                    idx = [
                        i for i, (kind, tg) in enumerate(active) if kind == "policy" and tg == tag
                    ]
                    net = run.opponent_net(tag)
                    a = opponent_action(net, torch.from_numpy(opp_obs[idx]), run.gen)
                    opp_actions[idx] = a.numpy()
                res = vec.step(action.numpy(), opp_actions)
                rewards = run.scaler(res.rewards, res.dones)
                if res.truncated.any():
                    idx = np.flatnonzero(res.truncated)
                    with torch.no_grad():
                        v = run.agent.value(torch.from_numpy(res.final_obs[idx])).numpy()
                    rewards[idx] += p.gamma * v
                obs_buf[t] = next_obs
                act_buf[t] = action.numpy()
                logp_buf[t] = logp.numpy()
                val_buf[t] = value.numpy()
                rew_buf[t] = rewards
                done_buf[t] = res.dones
                if advice is not None:
                    advice_buf[t] = advice
                deciding_buf[t] = True if deciding is None else deciding
                uncapped_buf[t] = False if uncapped is None else uncapped
                next_obs, opp_obs, advice = res.learner_obs, res.opponent_obs, res.advice
                deciding, uncapped = res.deciding, res.uncapped
                for ep in res.episodes:
                    finished.append(ep)
                    if ep.kind == "policy" and ep.result is not None:
                        run.pool.record(ep.tag, ep.result)
                    active[ep.slot] = pending[ep.slot]
                run.step += n
                swapped = run.pool.update(run.step, lambda: _weights(run.agent))
                if swapped is not None:
                    pending = [("policy", swapped.id) if k == POOL else (k, -1) for k in run.kinds]
                    vec.set_kinds(pending)
                in_use = {tag for kind, tag in active + pending if kind == "policy"}
                run.pool.retire(in_use)
                run.opponents = {i: a for i, a in run.opponents.items() if i in in_use}

            with torch.no_grad():
                last_value = run.agent.value(torch.from_numpy(next_obs)).numpy()
            adv, ret = compute_gae(rew_buf, val_buf, done_buf, last_value, p.gamma, p.gae_lambda)
            batch = Batch(
                obs=torch.from_numpy(obs_buf.reshape(-1, size)),
                actions=torch.from_numpy(act_buf.reshape(-1, action_size)),
                logprobs=torch.from_numpy(logp_buf.reshape(-1)),
                advantages=torch.from_numpy(adv.reshape(-1)),
                returns=torch.from_numpy(ret.reshape(-1)),
                values=torch.from_numpy(val_buf.reshape(-1)),
                advice=torch.from_numpy(advice_buf.reshape(-1, n_advice)),
                deciding=torch.from_numpy(deciding_buf.reshape(-1)),
            )
            torch.set_num_threads(cfg.torch_threads)
            imitation = cfg.imitation.coef_at(run.step)
            imitation_uncapped = cfg.imitation.coef_at(run.step, uncapped=True)
            weights = np.where(uncapped_buf.reshape(-1), imitation_uncapped, imitation)
            losses = ppo_update(
                run.agent, run.optimizer, batch, p, run.gen, torch.from_numpy(weights)
            )
            torch.set_num_threads(1)
            run.agent.obs_norm.update(obs_buf.reshape(-1, size))
            run.iteration += 1
            run.episodes += len(finished)
            elapsed = time.perf_counter() - t0
            run.wall_s += elapsed

            recent.extend(finished)
            stats = episode_summary(finished)
            stats.update({f"losses/{k}": v for k, v in losses.items()})
            stats["charts/steps_per_s"] = n * steps_per_env / elapsed
            stats["charts/learning_rate"] = run.optimizer.param_groups[0]["lr"]
            if cfg.imitation.teacher != "none":
                stats["charts/imitation_coef"] = imitation
                stats["charts/imitation_coef_uncapped"] = imitation_uncapped
            stats["selfplay/elo"] = run.pool.learner_elo
            stats["charts/episodes"] = float(run.episodes)
            for k, v in stats.items():
                if math.isfinite(v):
                    writer.add_scalar(k, v, run.step)
            stats["step"] = float(run.step)
            stats["wall_s"] = run.wall_s
            bar.update(min(run.step, cfg.total_steps) - bar.n)
            if recent:
                bar.set_postfix(
                    sps=f"{stats['charts/steps_per_s']:.0f}",
                    reward=f"{_mean([e.reward for e in recent]):.1f}",
                    rings=f"{_mean([float(e.rings) for e in recent]):.1f}",
                    elo=f"{run.pool.learner_elo:.0f}",
                    refresh=False,
                )

            ev_cfg = cfg.evaluation
            if ev_cfg.every_steps and run.step - last_eval >= ev_cfg.every_steps:
                last_eval = run.step
                ev = evaluate_agent(
                    run.agent,
                    run.spec,
                    ev_cfg.opponent,
                    ev_cfg.matches,
                    ev_cfg.seed,
                    run.env.skills,
                    runner,
                )
                for k, v in ev.items():
                    if math.isfinite(v):
                        writer.add_scalar(k, v, run.step)
                stats.update(ev)
                q = quality(ev)
                if q > run.best_quality:
                    run.best_quality = q
                    save_checkpoint(run.ckpt_dir / "best.pt", run.state())
            history.append(stats)
            with (run_dir / "history.jsonl").open("a") as f:
                f.write(json.dumps({k: v for k, v in stats.items() if math.isfinite(v)}) + "\n")
            if run.step - last_checkpoint >= cfg.checkpoint_steps:
                last_checkpoint = run.step
                run.checkpoint()
            if callback is not None and callback(
                Progress(run.step, run.iteration, run.wall_s, run.agent, run.spec, finished, stats)
            ):
                break
    except KeyboardInterrupt:
        # Ctrl-C (or SIGTERM through the CLI): keep what was learned; the iteration in flight
        # is dropped, the checkpoint and the export below still happen.
        interrupted = True
    finally:
        bar.close()
        vec.close()
        writer.close()
        torch.set_num_threads(threads)
    run.checkpoint()
    policy = None
    if export:
        training = {"config": cfg.name, "seed": cfg.seed, "steps": run.step, "wall_s": run.wall_s}
        policy, _ = export_policy(run.agent, run.spec, run.env, run_dir / "policy.onnx", training)
        best = run.ckpt_dir / "best.pt"
        if best.is_file():
            from sim.training.checkpoint import agent_from_checkpoint

            state = load_checkpoint(best)
            agent, spec, _ = agent_from_checkpoint(state)
            training_best = {**training, "steps": int(state["step"])}
            export_policy(agent, spec, run.env, run_dir / "best" / "policy.onnx", training_best)
    return TrainResult(run_dir, run.step, run.wall_s, run.episodes, policy, history, interrupted)
