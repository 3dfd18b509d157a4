"""Proximal Policy Optimisation for continuous actions, in the style of CleanRL: one file, read top
to bottom.

    agent = Agent(obs_size, action_size, PPOConfig())
    ...collect a Rollout with agent.act(...)...
    advantages, returns = compute_gae(rollout.rewards, rollout.values, rollout.dones, ...)
    stats = ppo_update(agent, optimizer, batch, cfg, generator)

What is here (Schulman et al. 2017, and the "37 implementation details" CleanRL follows):
  - a Gaussian policy with a state-independent log standard deviation and a separate value
    network, both MLPs with orthogonal initialisation;
  - generalised advantage estimation (GAE), with truncated episodes bootstrapped by the caller;
  - the clipped surrogate objective, a clipped value loss, an entropy bonus, per-minibatch
    advantage normalisation and global gradient-norm clipping;
  - an optional imitation term: the squared distance between the actor's mean and a teacher's
    action, where the batch carries one (NaN rows carry none), weighted per row (a weight of 0
    leaves the row untaught);
  - rows whose action the environment ignored (Batch.deciding False: a manoeuvre the policy
    committed to is under way) train the critic only, as in an options / semi-MDP setting;
  - running mean/variance normalisation of observations (saved with the policy, so the exported
    network sees the same inputs) and of rewards (scaled by the running standard deviation of the
    discounted return, as gymnasium's NormalizeReward does).

The learning-rate schedule, the environments and self-play live in sim.training; nothing here
knows about the simulator.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
import torch
from torch import nn

Activation = Literal["tanh", "silu", "relu"]
_ACTIVATIONS: dict[str, type[nn.Module]] = {"tanh": nn.Tanh, "silu": nn.SiLU, "relu": nn.ReLU}


@dataclass(frozen=True)
class PPOConfig:
    """The algorithm's hyperparameters (ML-Agents' names in brackets)."""

    learning_rate: float = 3e-4  # [learning_rate], decayed linearly to 0 when anneal_lr
    anneal_lr: bool = True  # [learning_rate_schedule: linear]
    gamma: float = 0.99  # [gamma]
    gae_lambda: float = 0.95  # [lambd]
    n_epochs: int = 3  # [num_epoch]
    minibatch_size: int = 1050  # [batch_size]
    clip_coef: float = 0.2  # [epsilon]
    clip_vloss: bool = True
    ent_coef: float = 0.005  # [beta]
    vf_coef: float = 0.5
    max_grad_norm: float = 0.5
    norm_adv: bool = True
    target_kl: float | None = None  # stop an update's epochs early past this KL
    hidden: tuple[int, ...] = (128, 128)  # [hidden_units] x [num_layers]
    activation: Activation = "tanh"
    init_log_std: float = 0.0  # std 1: an untrained robot's actions span the whole range
    init_action_bias: tuple[float, ...] = ()  # initial mean action (e.g. drive forward)
    norm_obs: bool = True  # [normalize]
    norm_reward: bool = True
    obs_clip: float = 10.0
    reward_clip: float = 10.0
    adam_eps: float = 1e-5

    def __post_init__(self) -> None:
        checks = {
            "learning_rate": self.learning_rate > 0,
            "gamma": 0 < self.gamma <= 1,
            "gae_lambda": 0 <= self.gae_lambda <= 1,
            "n_epochs": self.n_epochs >= 1,
            "minibatch_size": self.minibatch_size >= 1,
            "clip_coef": self.clip_coef > 0,
            "ent_coef": self.ent_coef >= 0,
            "vf_coef": self.vf_coef > 0,
            "max_grad_norm": self.max_grad_norm > 0,
            "hidden": len(self.hidden) >= 1 and all(h >= 1 for h in self.hidden),
            "obs_clip": self.obs_clip > 0,
            "reward_clip": self.reward_clip > 0,
        }
        bad = [name for name, ok in checks.items() if not ok]
        if bad:
            values = {name: getattr(self, name) for name in bad}
            raise ValueError(f"PPO config: out of range: {values}")
        if self.activation not in _ACTIVATIONS:
            raise ValueError(f"PPO config: activation must be one of {sorted(_ACTIVATIONS)}")
        if self.target_kl is not None and self.target_kl <= 0:
            raise ValueError("PPO config: target_kl must be positive or absent")


# --- normalisers ---------------------------------------------------------------------------------


class RunningMeanStd:
    """Mean and variance of a stream of vectors (Chan et al.'s parallel update), float64."""

    def __init__(self, shape: tuple[int, ...] = ()) -> None:
        self.mean = np.zeros(shape, dtype=np.float64)
        self.var = np.ones(shape, dtype=np.float64)
        self.count = 1e-4  # a tiny prior count keeps the first update finite

    def update(self, batch: np.ndarray) -> None:
        x = np.asarray(batch, dtype=np.float64).reshape(-1, *self.mean.shape)
        if len(x) == 0:
            return
        b_mean, b_var, b_count = x.mean(axis=0), x.var(axis=0), len(x)
        delta = b_mean - self.mean
        total = self.count + b_count
        self.mean = self.mean + delta * b_count / total
        m2 = self.var * self.count + b_var * b_count + delta**2 * self.count * b_count / total
        self.var = m2 / total
        self.count = total

    def state_dict(self) -> dict[str, Any]:
        return {"mean": self.mean.tolist(), "var": self.var.tolist(), "count": self.count}

    def load_state_dict(self, state: dict[str, Any]) -> None:
        self.mean = np.asarray(state["mean"], dtype=np.float64).reshape(self.mean.shape)
        self.var = np.asarray(state["var"], dtype=np.float64).reshape(self.var.shape)
        self.count = float(state["count"])


class ObsNormalizer(nn.Module):
    """(obs - mean) / sqrt(var + eps), clipped: part of the network, so export carries it.

    The statistics are buffers updated from rollouts (not by gradient descent); frozen, it is an
    affine map, which is what the exported ONNX graph contains.
    """

    def __init__(self, size: int, clip: float, enabled: bool, eps: float = 1e-8) -> None:
        super().__init__()
        self.enabled = enabled
        self.clip = clip
        self.eps = eps
        self.rms = RunningMeanStd((size,))
        self.register_buffer("mean", torch.zeros(size))
        self.register_buffer("inv_std", torch.ones(size))

    def update(self, obs: np.ndarray) -> None:
        if not self.enabled:
            return
        self.rms.update(obs)
        self.sync()

    def sync(self) -> None:
        """Copy the running statistics into the buffers the forward pass uses."""
        self.mean.copy_(torch.as_tensor(self.rms.mean, dtype=torch.float32))
        inv = 1.0 / np.sqrt(self.rms.var + self.eps)
        self.inv_std.copy_(torch.as_tensor(inv, dtype=torch.float32))

    def forward(self, obs: torch.Tensor) -> torch.Tensor:
        if not self.enabled:
            return obs
        return torch.clamp((obs - self.mean) * self.inv_std, -self.clip, self.clip)


class RewardScaler:
    """Divides rewards by the running std of the discounted return, per environment.

    Scaling (not centring) keeps the sign of every reward; the return estimate restarts when an
    episode ends. Without it, the prototype's deterministic policy stalled below the ring cap.
    """

    def __init__(self, n_envs: int, gamma: float, clip: float, enabled: bool) -> None:
        self.enabled = enabled
        self.gamma = gamma
        self.clip = clip
        self.rms = RunningMeanStd(())
        self.ret = np.zeros(n_envs, dtype=np.float64)

    def __call__(self, rewards: np.ndarray, dones: np.ndarray) -> np.ndarray:
        if not self.enabled:
            return rewards.astype(np.float32)
        self.ret = self.ret * self.gamma + rewards
        self.rms.update(self.ret)
        self.ret[dones] = 0.0
        scaled = rewards / math.sqrt(float(self.rms.var) + 1e-8)
        return np.clip(scaled, -self.clip, self.clip).astype(np.float32)

    def state_dict(self) -> dict[str, Any]:
        return {"rms": self.rms.state_dict(), "ret": self.ret.tolist()}

    def load_state_dict(self, state: dict[str, Any]) -> None:
        self.rms.load_state_dict(state["rms"])
        ret = np.asarray(state["ret"], dtype=np.float64)
        if ret.shape == self.ret.shape:
            self.ret = ret


# --- the network ---------------------------------------------------------------------------------


def _layer(n_in: int, n_out: int, std: float) -> nn.Linear:
    layer = nn.Linear(n_in, n_out)
    nn.init.orthogonal_(layer.weight, std)
    nn.init.constant_(layer.bias, 0.0)
    return layer


def _mlp(n_in: int, hidden: tuple[int, ...], n_out: int, act: str, out_std: float) -> nn.Sequential:
    layers: list[nn.Module] = []
    size = n_in
    for h in hidden:
        layers += [_layer(size, h, math.sqrt(2)), _ACTIVATIONS[act]()]
        size = h
    layers.append(_layer(size, n_out, out_std))
    return nn.Sequential(*layers)


class Agent(nn.Module):
    """Actor (Gaussian mean and log std) and critic, each its own MLP, behind one normaliser."""

    def __init__(self, obs_size: int, action_size: int, cfg: PPOConfig) -> None:
        super().__init__()
        self.obs_size = obs_size
        self.action_size = action_size
        self.obs_norm = ObsNormalizer(obs_size, cfg.obs_clip, cfg.norm_obs)
        self.critic = _mlp(obs_size, cfg.hidden, 1, cfg.activation, 1.0)
        # A small last layer: the initial policy is close to its bias, whatever the input.
        self.actor_mean = _mlp(obs_size, cfg.hidden, action_size, cfg.activation, 0.01)
        self.actor_logstd = nn.Parameter(torch.full((1, action_size), cfg.init_log_std))
        if cfg.init_action_bias:
            if len(cfg.init_action_bias) != action_size:
                raise ValueError(
                    f"init_action_bias has {len(cfg.init_action_bias)} values, "
                    f"the action has {action_size}"
                )
            last = self.actor_mean[-1]
            assert isinstance(last, nn.Linear)
            with torch.no_grad():
                last.bias.copy_(torch.tensor(cfg.init_action_bias, dtype=torch.float32))

    def value(self, obs: torch.Tensor) -> torch.Tensor:
        return self.critic(self.obs_norm(obs)).squeeze(-1)

    def distribution(self, obs: torch.Tensor) -> torch.distributions.Normal:
        mean = self.actor_mean(self.obs_norm(obs))
        std = torch.exp(self.actor_logstd.expand_as(mean))
        return torch.distributions.Normal(mean, std)

    def deterministic(self, obs: torch.Tensor) -> torch.Tensor:
        """The action the robot executes: the mean, clipped to the action range."""
        return torch.clamp(self.actor_mean(self.obs_norm(obs)), -1.0, 1.0)

    @torch.no_grad()
    def act(
        self, obs: torch.Tensor, generator: torch.Generator | None = None
    ) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        """Sample an action; returns (action, log-prob, value). The action is unclipped (the
        environment clips it), so its log-probability is exact."""
        dist = self.distribution(obs)
        noise = torch.randn(dist.mean.shape, generator=generator)
        action = dist.mean + dist.stddev * noise
        return action, dist.log_prob(action).sum(-1), self.value(obs)

    def evaluate(
        self, obs: torch.Tensor, action: torch.Tensor
    ) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        """(log-prob of action, entropy, value) under the current parameters."""
        dist = self.distribution(obs)
        return dist.log_prob(action).sum(-1), dist.entropy().sum(-1), self.value(obs)


# --- advantages ----------------------------------------------------------------------------------


def compute_gae(
    rewards: np.ndarray,
    values: np.ndarray,
    dones: np.ndarray,
    last_values: np.ndarray,
    gamma: float,
    lam: float,
) -> tuple[np.ndarray, np.ndarray]:
    """Generalised advantage estimates and returns for arrays of shape (steps, envs).

    dones[t] is True when the episode ended with step t (the next observation starts a new
    episode, so nothing is bootstrapped across it); last_values are V(s_T) of the observation
    after the rollout. A truncated episode is the caller's to bootstrap: add gamma * V(final obs)
    to its last reward.
    """
    steps = rewards.shape[0]
    adv = np.zeros_like(rewards, dtype=np.float32)
    last = np.zeros(rewards.shape[1:], dtype=np.float32)
    for t in reversed(range(steps)):
        next_value = last_values if t == steps - 1 else values[t + 1]
        nonterminal = 1.0 - dones[t].astype(np.float32)
        delta = rewards[t] + gamma * next_value * nonterminal - values[t]
        last = delta + gamma * lam * nonterminal * last
        adv[t] = last
    return adv, adv + values


# --- the update ----------------------------------------------------------------------------------


@dataclass
class Batch:
    """One rollout, flattened over (steps, envs)."""

    obs: torch.Tensor
    actions: torch.Tensor
    logprobs: torch.Tensor
    advantages: torch.Tensor
    returns: torch.Tensor
    values: torch.Tensor
    # A teacher's action per row, (rows, k) for the first k action dimensions; NaN: no label.
    advice: torch.Tensor | None = None
    # Per row, whether its action decided anything (False: the environment ignored it, e.g.
    # during a manoeuvre the policy committed to); such rows train the critic only.
    deciding: torch.Tensor | None = None

    def __len__(self) -> int:
        return int(self.obs.shape[0])


def ppo_update(
    agent: Agent,
    optimizer: torch.optim.Optimizer,
    batch: Batch,
    cfg: PPOConfig,
    generator: torch.Generator | None = None,
    imitation_coef: float | torch.Tensor = 0.0,
) -> dict[str, float]:
    """n_epochs passes of minibatch gradient steps on the clipped objective (plus the imitation
    term when the batch has advice, weighted by imitation_coef: one number, or one per row);
    returns statistics."""
    n = len(batch)
    im_weight = torch.as_tensor(imitation_coef, dtype=torch.float32).expand(n)
    imitate = batch.advice is not None and bool((im_weight > 0).any())
    mb = min(cfg.minibatch_size, n)
    clipfracs: list[float] = []
    stats: dict[str, float] = {}
    approx_kl = torch.zeros(())
    for _epoch in range(cfg.n_epochs):
        order = torch.randperm(n, generator=generator)
        for start in range(0, n, mb):
            idx = order[start : start + mb]
            logprob, entropy, value = agent.evaluate(batch.obs[idx], batch.actions[idx])
            logratio = logprob - batch.logprobs[idx]
            ratio = logratio.exp()
            with torch.no_grad():
                # The low-variance KL estimator ((r - 1) - log r), http://joschu.net/blog/kl-approx.html
                approx_kl = ((ratio - 1) - logratio).mean()
                clipfracs.append(float(((ratio - 1.0).abs() > cfg.clip_coef).float().mean()))

            adv = batch.advantages[idx]
            if cfg.norm_adv and len(idx) > 1:
                adv = (adv - adv.mean()) / (adv.std() + 1e-8)
            pg_rows = torch.max(
                -adv * ratio, -adv * torch.clamp(ratio, 1 - cfg.clip_coef, 1 + cfg.clip_coef)
            )
            if batch.deciding is None:
                pg_loss, ent = pg_rows.mean(), entropy.mean()
            else:
                w = batch.deciding[idx].float()
                pg_loss = (pg_rows * w).sum() / w.sum().clamp(min=1.0)
                ent = (entropy * w).sum() / w.sum().clamp(min=1.0)

            ret = batch.returns[idx]
            if cfg.clip_vloss:
                old = batch.values[idx]
                clipped = old + torch.clamp(value - old, -cfg.clip_coef, cfg.clip_coef)
                v_loss = 0.5 * torch.max((value - ret) ** 2, (clipped - ret) ** 2).mean()
            else:
                v_loss = 0.5 * ((value - ret) ** 2).mean()

            loss = pg_loss - cfg.ent_coef * ent + cfg.vf_coef * v_loss
            im_loss = torch.zeros(())
            if imitate:
                assert batch.advice is not None
                target = batch.advice[idx]
                # Rows whose weight is 0 (a game whose teacher has left) are not taught, and
                # do not dilute the rows that are.
                labelled = torch.isfinite(target).all(-1) & (im_weight[idx] > 0)
                if batch.deciding is not None:
                    labelled &= batch.deciding[idx]
                if bool(labelled.any()):
                    k = target.shape[-1]
                    mean = agent.actor_mean(agent.obs_norm(batch.obs[idx][labelled]))[:, :k]
                    rows = ((mean - target[labelled]) ** 2).sum(-1)
                    im_loss = rows.mean()
                    loss = loss + (im_weight[idx][labelled] * rows).mean()
            optimizer.zero_grad()
            loss.backward()
            nn.utils.clip_grad_norm_(agent.parameters(), cfg.max_grad_norm)
            optimizer.step()
            stats = {
                "policy_loss": float(pg_loss.detach()),
                "value_loss": float(v_loss.detach()),
                "entropy": float(ent.detach()),
            }
            if imitate:
                stats["imitation_loss"] = float(im_loss.detach())
        if cfg.target_kl is not None and float(approx_kl) > cfg.target_kl:
            break

    y_pred, y_true = batch.values.numpy(), batch.returns.numpy()
    var_y = float(np.var(y_true))
    explained = math.nan if var_y == 0 else 1.0 - float(np.var(y_true - y_pred)) / var_y
    stats.update(
        approx_kl=float(approx_kl),
        clipfrac=float(np.mean(clipfracs)) if clipfracs else 0.0,
        explained_variance=explained,
        action_std=float(torch.exp(agent.actor_logstd.detach()).mean()),
    )
    return stats
