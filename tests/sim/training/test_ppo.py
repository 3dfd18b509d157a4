"""sim.ppo: GAE, the normalisers, the network and the update, on problems with known answers."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from sim.ppo import Agent, Batch, PPOConfig, RewardScaler, RunningMeanStd, compute_gae, ppo_update


def test_gae_matches_a_hand_computation() -> None:
    gamma, lam = 0.9, 0.8
    rewards = np.array([[1.0], [0.0], [2.0]], np.float32)
    values = np.array([[0.5], [0.4], [0.3]], np.float32)
    dones = np.array([[False], [True], [False]])
    last = np.array([1.0], np.float32)
    adv, ret = compute_gae(rewards, values, dones, last, gamma, lam)
    # t=2: delta = 2 + 0.9 * 1.0 - 0.3; t=1 ends the episode: delta = 0 - 0.4, nothing after;
    # t=0: delta = 1 + 0.9 * 0.4 - 0.5, plus gamma * lam * A1.
    a2 = 2 + 0.9 * 1.0 - 0.3
    a1 = 0 - 0.4
    a0 = (1 + 0.9 * 0.4 - 0.5) + 0.9 * 0.8 * a1
    np.testing.assert_allclose(adv[:, 0], [a0, a1, a2], rtol=1e-6)
    np.testing.assert_allclose(ret, adv + values, rtol=1e-6)


def test_gae_with_lambda_one_is_the_discounted_return_minus_value() -> None:
    rng = np.random.default_rng(0)
    r = rng.normal(size=(6, 3)).astype(np.float32)
    v = rng.normal(size=(6, 3)).astype(np.float32)
    dones = np.zeros((6, 3), bool)
    last = rng.normal(size=3).astype(np.float32)
    adv, _ = compute_gae(r, v, dones, last, 0.95, 1.0)
    g = last.copy()
    for t in reversed(range(6)):
        g = r[t] + 0.95 * g
        np.testing.assert_allclose(adv[t], g - v[t], rtol=1e-5, atol=1e-5)


def test_running_mean_std_equals_numpy_over_all_batches() -> None:
    rng = np.random.default_rng(1)
    data = [rng.normal(3.0, 2.0, size=(n, 4)) for n in (5, 17, 1, 40)]
    rms = RunningMeanStd((4,))
    for batch in data:
        rms.update(batch)
    everything = np.concatenate(data)
    np.testing.assert_allclose(rms.mean, everything.mean(axis=0), rtol=1e-4)
    np.testing.assert_allclose(rms.var, everything.var(axis=0), rtol=1e-3)
    copy = RunningMeanStd((4,))
    copy.load_state_dict(rms.state_dict())
    np.testing.assert_array_equal(copy.mean, rms.mean)


def test_reward_scaler_keeps_signs_and_restarts_returns() -> None:
    scaler = RewardScaler(2, gamma=0.99, clip=10.0, enabled=True)
    for _ in range(50):
        out = scaler(np.array([5.0, -5.0]), np.array([False, False]))
    assert out[0] > 0 > out[1]
    assert abs(out[0]) < 5.0, "scaled down by the return's spread"
    scaler(np.array([1.0, 1.0]), np.array([True, False]))
    assert scaler.ret[0] == 0.0 and scaler.ret[1] != 0.0
    off = RewardScaler(1, 0.99, 10.0, enabled=False)
    assert off(np.array([7.0]), np.array([False]))[0] == 7.0


def test_observation_normaliser_is_inside_the_network() -> None:
    agent = Agent(3, 2, PPOConfig(hidden=(8,)))
    obs = np.array([[10.0, 0.0, -4.0], [12.0, 2.0, -4.0]], np.float32)
    agent.obs_norm.update(obs)
    normed = agent.obs_norm(torch.as_tensor(obs))
    assert normed[:, 0].tolist() == pytest.approx([-1.0, 1.0], abs=1e-2)
    assert normed[:, 2].abs().max() < 0.05, "a constant input maps to about 0"
    off = Agent(3, 2, PPOConfig(hidden=(8,), norm_obs=False))
    off.obs_norm.update(obs)
    assert torch.equal(off.obs_norm(torch.as_tensor(obs)), torch.as_tensor(obs))


def test_initial_policy_moves_and_can_be_biased() -> None:
    agent = Agent(4, 2, PPOConfig(hidden=(16,), init_action_bias=(0.5, 0.0)))
    gen = torch.Generator().manual_seed(0)
    obs = torch.zeros(256, 4)
    actions, logp, value = agent.act(obs, gen)
    assert actions.shape == (256, 2) and logp.shape == (256,) and value.shape == (256,)
    assert actions.std(dim=0).min() > 0.8, "std 1: an untrained robot's actions span the range"
    assert agent.deterministic(obs)[:, 0].mean().item() == pytest.approx(0.5, abs=0.05)
    with pytest.raises(ValueError, match="init_action_bias"):
        Agent(4, 2, PPOConfig(init_action_bias=(1.0,)))


def test_bad_hyperparameters_are_named() -> None:
    with pytest.raises(ValueError, match="gamma"):
        PPOConfig(gamma=1.5)
    with pytest.raises(ValueError, match="activation"):
        PPOConfig(activation="gelu")  # type: ignore[arg-type]


def test_update_moves_the_policy_towards_the_better_action() -> None:
    """A one-step bandit: reward -(a - 0.6)^2. PPO must move the mean action towards 0.6."""
    threads = torch.get_num_threads()
    # Tiny matrices: a second thread only waits for the other jobs on a busy 2-core machine.
    torch.set_num_threads(1)
    try:
        _bandit()
    finally:
        torch.set_num_threads(threads)


def _bandit() -> None:
    torch.manual_seed(0)
    gen = torch.Generator().manual_seed(0)
    cfg = PPOConfig(hidden=(16,), learning_rate=3e-3, n_epochs=4, minibatch_size=128)
    agent = Agent(2, 1, cfg)
    opt = torch.optim.Adam(agent.parameters(), lr=cfg.learning_rate)
    obs = torch.ones(256, 2)
    start = agent.deterministic(obs[:1]).item()
    for _ in range(30):
        actions, logp, values = agent.act(obs, gen)
        rewards = -((actions[:, 0] - 0.6) ** 2)
        adv = (rewards - values).numpy()
        batch = Batch(obs, actions, logp, torch.as_tensor(adv), rewards, values)
        stats = ppo_update(agent, opt, batch, cfg, gen)
    end = agent.deterministic(obs[:1]).item()
    assert abs(end - 0.6) < 0.15 < abs(start - 0.6)
    assert set(stats) >= {"policy_loss", "value_loss", "entropy", "approx_kl", "clipfrac"}


def test_imitation_pulls_the_mean_to_the_teacher_and_skips_unlabelled_rows() -> None:
    """No advantage signal at all: only the imitation term can move the policy, and only rows
    with advice count (NaN rows must neither move it nor poison the loss)."""
    threads = torch.get_num_threads()
    torch.set_num_threads(1)
    try:
        torch.manual_seed(0)
        gen = torch.Generator().manual_seed(0)
        cfg = PPOConfig(hidden=(16,), learning_rate=3e-3, n_epochs=4, minibatch_size=64)
        agent = Agent(2, 2, cfg)
        opt = torch.optim.Adam(agent.parameters(), lr=cfg.learning_rate)
        obs = torch.cat([torch.ones(128, 2), -torch.ones(128, 2)])
        advice = torch.full((256, 2), float("nan"))
        advice[:128] = torch.tensor([0.7, -0.4])  # a label for the first state only
        zeros = torch.zeros(256)
        for _ in range(40):
            actions, logp, values = agent.act(obs, gen)
            batch = Batch(obs, actions, logp, zeros, values, values, advice)
            stats = ppo_update(agent, opt, batch, cfg, gen, imitation_coef=1.0)
        labelled = agent.deterministic(obs[:1])[0]
        assert torch.allclose(labelled, torch.tensor([0.7, -0.4]), atol=0.05), labelled
        assert np.isfinite(stats["imitation_loss"]) and stats["imitation_loss"] < 0.01
        # Without a coefficient the same batch leaves the mean where it is.
        before = agent.deterministic(obs).detach().clone()
        stats = ppo_update(
            agent, opt, Batch(obs, actions, logp, zeros, values, values, advice), cfg, gen
        )
        assert "imitation_loss" not in stats
        assert torch.allclose(agent.deterministic(obs), before, atol=0.02)
    finally:
        torch.set_num_threads(threads)


def test_a_per_row_imitation_weight_teaches_only_the_weighted_rows() -> None:
    """Two states, both labelled; a weight of 0 on the second (a capped match after its
    teacher left) keeps it where it was while the first is pulled to its label."""
    threads = torch.get_num_threads()
    torch.set_num_threads(1)
    try:
        torch.manual_seed(0)
        gen = torch.Generator().manual_seed(0)
        cfg = PPOConfig(hidden=(16,), learning_rate=3e-3, n_epochs=4, minibatch_size=64)
        agent = Agent(2, 2, cfg)
        opt = torch.optim.Adam(agent.parameters(), lr=cfg.learning_rate)
        obs = torch.cat([torch.ones(128, 2), -torch.ones(128, 2)])
        advice = torch.cat([torch.tensor([[0.7, -0.4]]).expand(128, 2), torch.ones(128, 2)])
        weight = torch.cat([torch.ones(128), torch.zeros(128)])
        zeros = torch.zeros(256)
        before = agent.deterministic(obs[128:129]).detach().clone()
        for _ in range(40):
            actions, logp, values = agent.act(obs, gen)
            batch = Batch(obs, actions, logp, zeros, values, values, advice)
            ppo_update(agent, opt, batch, cfg, gen, imitation_coef=weight)
        taught = agent.deterministic(obs[:1])[0]
        assert torch.allclose(taught, torch.tensor([0.7, -0.4]), atol=0.05), taught
        untaught = agent.deterministic(obs[128:129])
        # Shared weights move it a little; its own label (1, 1) would have moved it all the way.
        assert (untaught - 1.0).abs().min() > 0.5, (before, untaught)
    finally:
        torch.set_num_threads(threads)


def test_rows_whose_action_decided_nothing_train_only_the_critic() -> None:
    torch.manual_seed(0)
    cfg = PPOConfig(hidden=(8,), n_epochs=2, minibatch_size=16, ent_coef=0.01)
    rows = 32

    def run(deciding: bool) -> tuple[bool, bool]:
        torch.manual_seed(1)
        agent = Agent(4, 2, cfg)
        actor = [q.detach().clone() for q in agent.actor_mean.parameters()]
        critic = [q.detach().clone() for q in agent.critic.parameters()]
        optimizer = torch.optim.Adam(agent.parameters(), lr=1e-2)
        g = torch.Generator().manual_seed(2)
        obs = torch.randn(rows, 4, generator=g)
        actions = torch.randn(rows, 2, generator=g)
        with torch.no_grad():
            logp, _, values = agent.evaluate(obs, actions)
        batch = Batch(
            obs, actions, logp, torch.randn(rows, generator=g), torch.randn(rows, generator=g),
            values, deciding=torch.full((rows,), deciding),
        )  # fmt: skip
        ppo_update(agent, optimizer, batch, cfg, g)
        moved_actor = any(
            not torch.equal(a, b) for a, b in zip(actor, agent.actor_mean.parameters(), strict=True)
        )
        moved_critic = any(
            not torch.equal(a, b) for a, b in zip(critic, agent.critic.parameters(), strict=True)
        )
        return moved_actor, moved_critic

    assert run(True) == (True, True)
    assert run(False) == (False, True)
