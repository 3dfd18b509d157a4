"""Benchmark of the whole game: the scripted alliance against the ring-race alliance and itself.

    python -m bench.game [--seeds 40] [--first-seed 0] [--fidelity high|training] [--jobs 2]
                         [--results DIR] [--strict]

Every match is the 2v2 whole game (`world_preset("tipping_point_2v2")`: a 24" and a 15" robot an
alliance, 15 s isolation + 105 s interaction) with the robots' GPS noise on. The scripted alliance
(jetson/autonomy/alliance.py, hosted by sim/baselines/alliance.py) plays:

(a) the ring-race alliance (sim/baselines/alliance.py: the route planner without its endgame on
    the 24", the greedy chaser on the 15"), `--seeds` matches, the scripted alliance red on even
    seeds and blue on odd ones (sides swapped in half);
(b) itself, `--seeds` matches;
(c) the ring-race alliance again with the steal off (`AllianceConfig.steal_s` None: the 24"
    scores rings and neutral goals through the interaction period instead of taking neutral goals
    home, the other alliance's loaded one first; both robots climb), `--seeds` matches
    (`--no-climb-only` skips them).

The scripted alliance plays its defaults in (a) and (b): the steal from the interaction period's
start, then the climb (jetson/autonomy/alliance.py, `steal_s`, `steal_climb`).

Measured (vs: the ring-race alliance, self: itself; per match means):
- win rate against (a) by match score (target >= 0.9; a draw counts half), and the same with the
  credit for the other side's platform-protection fouls taken out of the scripted alliance's
  score (no target: the credit is part of the score; <SG3> credits an Elevated robot a
  violation, at most two with the alliance's own, rules.platform_credit);
- the share of the interaction period the scripted robots are still (measured speed under
  3 cm/s and turn under 0.1 rad/s, off their own platform: a robot waiting on its board keeps
  the ramp down or holds the balance) while rings are left on the floor (target < 0.1, over
  both robots and every match); `still_share_interaction_counting_own_platform` counts those
  on the platform too (no target: the 15"'s sentry waits there by design);
- the share of matches against (a) that end with its platform Balanced and both its robots
  Elevated (target >= 0.8);
- with the steal off (c), `vs_ring_race_climb_only_*`: the win rate, the mean scores, the share
  of matches Balanced with both robots Elevated and the still share (no targets: the targets
  above are the default alliance's);
- fouls per match of each alliance, by kind, and the share of matches in which one of its robots
  touches the opposing platform as the match ends (<SG3>: a Disqualification in the manual,
  reported and not scored); mean scores and the score by element (rings on a
  high branch, low branch and base as points, goals in the home zone, goals and robots Elevated,
  credit for the opponent's platform fouls, the autonomous bonus, the win point's rate).

Results: bench/results/game.json (`--results` elsewhere for development runs).
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from dataclasses import asdict, dataclass, field
from multiprocessing import get_context
from pathlib import Path

import numpy as np

from bench.common import RESULTS_DIR, Result
from jetson.autonomy.alliance import AllianceConfig
from sim.baselines.alliance import AlliancePlayer, ring_race_player
from sim.config import world_preset
from sim.match import EnvConfig, MatchCore
from sim.players import Player
from sim.world import rules
from sim.world.state import RING_FLOOR, AllianceScore

WIN_TARGET = 0.9
STILL_TARGET = 0.1
BALANCED_TARGET = 0.8
STILL_SPEED_MPS = 0.03
STILL_TURN_RAD_S = 0.1


@dataclass
class GameRecord:
    seed: int
    opponent: str  # "ring_race" or "self"
    ours: str  # the scripted alliance's colour (red in self-play)
    score: dict[str, int]  # by alliance
    elements: dict[str, dict[str, float]]  # by alliance: points by element
    fouls: dict[str, dict[str, int]]  # by alliance: count by kind
    balanced_both_up: dict[str, bool]  # by alliance: Balanced with both robots Elevated
    still_steps: int = 0  # the scripted robots' still steps (interaction, rings on the floor)
    still_on_platform_steps: int = 0  # still steps on their own platform (not in still_steps)
    counted_steps: int = 0
    wall_s: float = 0.0
    awp: dict[str, bool] = field(default_factory=dict)
    # by alliance: one of its robots touched the opposing platform as the match ended (<SG3>
    # Note 2: a Disqualification in the manual; reported, not scored)
    platform_contact_at_end: dict[str, bool] = field(default_factory=dict)
    climb_only: bool = False  # the scripted alliance played with the steal off (c)


def elements(s: AllianceScore) -> dict[str, float]:
    """An alliance's score by element, in points (the field file's values)."""
    return {
        "rings_high": 10.0 * s.rings_high,
        "rings_low": 3.0 * s.rings_low,
        "rings_base": 1.0 * s.rings_base,
        "goals_in_zone": 20.0 * s.goals_in_zone,
        "goals_elevated": 40.0 * s.goals_elevated,
        "robots_elevated": 30.0 * s.robots_elevated,
        "foul_credit": 30.0 * s.foul_credit,
        "autonomous_bonus": float(s.autonomous_bonus),
    }


def play(seed: int, fidelity: str, opponent: str, climb_only: bool = False) -> GameRecord:
    """One seeded 2v2 whole-game match (see the module docstring); `climb_only`: the scripted
    alliance with the steal off."""
    start = time.perf_counter()
    env = EnvConfig(
        world=world_preset("tipping_point_2v2", fidelity=fidelity),
        obs_noise=False,
        gps_noise=True,
    )
    core = MatchCore(env)
    try:
        core.reset(np.random.default_rng(seed))
        w = core.world
        ours = "red" if opponent == "self" or seed % 2 == 0 else "blue"
        players: list[Player] = []
        for r in w.robots:
            if r.alliance == ours or opponent == "self":
                config = AllianceConfig(steal_s=None) if climb_only else None
                players.append(AlliancePlayer(config))
            else:
                players.append(ring_race_player(r.config.name))
        for i, p in enumerate(players):
            p.reset(core, i, np.random.default_rng((seed, i)))
        mine = [r.index for r in w.robots if r.alliance == ours]
        still = still_up = counted = 0
        while not w.over:
            commands = [p.act(core, i, None) for i, p in enumerate(players)]
            w.step(commands)
            if w.time_s <= w.isolation_s + 1e-9 or not np.any(w.ring_state == RING_FLOOR):
                continue
            for i in mine:
                r = w.robots[i]
                counted += 1
                if abs(r.measured_v) < STILL_SPEED_MPS and abs(r.measured_w) < STILL_TURN_RAD_S:
                    if r.on_platform == r.alliance:
                        still_up += 1
                    else:
                        still += 1
        score = w.score()
        fouls: dict[str, dict[str, int]] = {"red": {}, "blue": {}}
        for f in w.fouls:
            fouls[f.alliance][f.kind] = fouls[f.alliance].get(f.kind, 0) + 1
        up = {
            a: bool(
                rules.platform_balanced(w, a)
                and all(rules.robot_elevated(w, r) for r in w.robots if r.alliance == a)
            )
            for a in ("red", "blue")
        }
        return GameRecord(
            seed=seed,
            opponent=opponent,
            ours=ours,
            score={a: int(score[a].total) for a in ("red", "blue")},
            elements={a: elements(score[a]) for a in ("red", "blue")},
            fouls=fouls,
            balanced_both_up=up,
            still_steps=still,
            still_on_platform_steps=still_up,
            counted_steps=counted,
            wall_s=time.perf_counter() - start,
            awp={a: bool(score[a].autonomous_win_point) for a in ("red", "blue")},
            platform_contact_at_end=rules.platform_contact_at_end(w),
            climb_only=climb_only,
        )
    finally:
        core.close()


def _play(job: tuple[int, str, str, bool]) -> GameRecord:
    return play(*job)


def run(seeds: list[int], fidelity: str, jobs: int, climb_only: bool = True) -> list[GameRecord]:
    work = [(s, fidelity, opp, False) for opp in ("ring_race", "self") for s in seeds]
    if climb_only:
        work += [(s, fidelity, "ring_race", True) for s in seeds]
    if jobs <= 1:
        return [_play(j) for j in work]
    with get_context("spawn").Pool(jobs) as pool:
        return pool.map(_play, work, chunksize=1)


def other(alliance: str) -> str:
    return "blue" if alliance == "red" else "red"


def _win_rate(records: list[GameRecord]) -> float:
    """Matches won by score, a draw counting half."""
    wins = sum(
        1.0 if g.score[g.ours] > g.score[other(g.ours)] else
        0.5 if g.score[g.ours] == g.score[other(g.ours)] else 0.0
        for g in records
    )  # fmt: skip
    return wins / len(records)


def summarise(records: list[GameRecord], fidelity: str) -> Result:
    r = Result("game")
    vs = [g for g in records if g.opponent == "ring_race" and not g.climb_only]
    climbing = [g for g in records if g.opponent == "ring_race" and g.climb_only]
    selfplay = [g for g in records if g.opponent == "self"]
    r.add("seeds", len(vs))
    r.add("high_fidelity", 1 if fidelity == "high" else 0)
    if vs:
        r.add("vs_ring_race_win_rate", _win_rate(vs))
        # The same with the credit for the ring-race alliance's platform-protection fouls taken
        # out of the scripted alliance's score (the credit tops its Elevated robots up to two,
        # rules.platform_credit).
        plain = [g.score[g.ours] - g.elements[g.ours]["foul_credit"] for g in vs]
        theirs = [g.score[other(g.ours)] for g in vs]
        plain_wins = sum(
            1.0 if a > b else 0.5 if a == b else 0.0 for a, b in zip(plain, theirs, strict=True)
        )
        r.add("vs_ring_race_win_rate_without_foul_credit", plain_wins / len(vs))
        r.add("vs_ring_race_score_ours_without_foul_credit", statistics.fmean(plain))
        r.add("vs_ring_race_score_ours", statistics.fmean(g.score[g.ours] for g in vs))
        r.add("vs_ring_race_score_theirs", statistics.fmean(g.score[other(g.ours)] for g in vs))
        r.add(
            "vs_ring_race_score_margin_min",
            min(g.score[g.ours] - g.score[other(g.ours)] for g in vs),
        )
        r.add(
            "vs_ring_race_balanced_both_elevated_rate",
            statistics.fmean(float(g.balanced_both_up[g.ours]) for g in vs),
        )
        for key in vs[0].elements["red"]:
            r.add(f"vs_ring_race_ours_{key}", statistics.fmean(g.elements[g.ours][key] for g in vs))
            r.add(
                f"vs_ring_race_theirs_{key}",
                statistics.fmean(g.elements[other(g.ours)][key] for g in vs),
            )
        r.add("vs_ring_race_awp_rate", statistics.fmean(float(g.awp[g.ours]) for g in vs))
        r.add(
            "vs_ring_race_fouls_ours_per_match",
            statistics.fmean(sum(g.fouls[g.ours].values()) for g in vs),
        )
        r.add(
            "vs_ring_race_fouls_theirs_per_match",
            statistics.fmean(sum(g.fouls[other(g.ours)].values()) for g in vs),
        )
        for kind in ("isolation_contact", "platform_protection"):
            r.add(
                f"vs_ring_race_fouls_ours_{kind}",
                statistics.fmean(g.fouls[g.ours].get(kind, 0) for g in vs),
            )
            r.add(
                f"vs_ring_race_fouls_theirs_{kind}",
                statistics.fmean(g.fouls[other(g.ours)].get(kind, 0) for g in vs),
            )
        for side, pick in (("ours", lambda g: g.ours), ("theirs", lambda g: other(g.ours))):
            r.add(
                f"vs_ring_race_{side}_platform_contact_at_end_rate",
                statistics.fmean(float(g.platform_contact_at_end.get(pick(g), False)) for g in vs),
            )
    if selfplay:
        both = [s for g in selfplay for s in g.score.values()]
        r.add("self_score_mean", statistics.fmean(both))
        r.add(
            "self_balanced_both_elevated_rate",
            statistics.fmean(float(v) for g in selfplay for v in g.balanced_both_up.values()),
        )
        r.add(
            "self_fouls_per_match",
            statistics.fmean(sum(sum(k.values()) for k in g.fouls.values()) for g in selfplay),
        )
        r.add(
            "self_isolation_fouls_per_match",
            statistics.fmean(
                sum(k.get("isolation_contact", 0) for k in g.fouls.values()) for g in selfplay
            ),
        )
        for key in selfplay[0].elements["red"]:
            r.add(
                f"self_{key}",
                statistics.fmean(v[key] for g in selfplay for v in g.elements.values()),
            )
    if climbing:
        r.add("vs_ring_race_climb_only_win_rate", _win_rate(climbing))
        r.add(
            "vs_ring_race_climb_only_score_ours",
            statistics.fmean(g.score[g.ours] for g in climbing),
        )
        r.add(
            "vs_ring_race_climb_only_score_theirs",
            statistics.fmean(g.score[other(g.ours)] for g in climbing),
        )
        r.add(
            "vs_ring_race_climb_only_balanced_both_elevated_rate",
            statistics.fmean(float(g.balanced_both_up[g.ours]) for g in climbing),
        )
        r.add(
            "vs_ring_race_climb_only_fouls_ours_per_match",
            statistics.fmean(sum(g.fouls[g.ours].values()) for g in climbing),
        )
        n = sum(g.counted_steps for g in climbing)
        r.add(
            "vs_ring_race_climb_only_still_share_interaction",
            sum(g.still_steps for g in climbing) / n if n else 0.0,
        )
    default = vs + selfplay
    counted = sum(g.counted_steps for g in default)
    r.add(
        "still_share_interaction", sum(g.still_steps for g in default) / counted if counted else 0.0
    )
    up = sum(g.still_steps + g.still_on_platform_steps for g in default)
    r.add("still_share_interaction_counting_own_platform", up / counted if counted else 0.0)
    r.add("match_wall_s_median", statistics.median(g.wall_s for g in records))
    r.target("vs_ring_race_win_rate", WIN_TARGET, ">=")
    r.target("still_share_interaction", STILL_TARGET, "<=")
    r.target("vs_ring_race_balanced_both_elevated_rate", BALANCED_TARGET, ">=")
    return r


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(
        description=__doc__.splitlines()[0], formatter_class=argparse.RawDescriptionHelpFormatter
    )
    ap.add_argument("--seeds", type=int, default=40, help="matches per opponent (default 40)")
    ap.add_argument("--first-seed", type=int, default=0)
    ap.add_argument("--fidelity", choices=("high", "training"), default="high")
    ap.add_argument("--jobs", type=int, default=1, help="processes (default 1)")
    ap.add_argument("--results", type=Path, default=RESULTS_DIR, help="where game.json goes")
    ap.add_argument("--matches", action="store_true", help="print one line per match")
    ap.add_argument("--strict", action="store_true", help="exit 1 when a target is missed")
    ap.add_argument(
        "--no-climb-only", action="store_true", help="skip (c), the matches with the steal off"
    )
    args = ap.parse_args(argv)
    if args.seeds < 1 or args.jobs < 1:
        ap.error("--seeds and --jobs must be at least 1")
    seeds = list(range(args.first_seed, args.first_seed + args.seeds))
    records = run(seeds, args.fidelity, args.jobs, climb_only=not args.no_climb_only)
    if args.matches:
        for g in records:
            them = other(g.ours)
            print(
                f"seed {g.seed:3d} {g.opponent + ('+climb-only' if g.climb_only else ''):20s} "
                f"ours={g.ours:4s} "
                f"{g.score[g.ours]:4d}-{g.score[them]:<4d} up={int(g.balanced_both_up[g.ours])}"
                f"{int(g.balanced_both_up[them])} still={g.still_steps}/{g.counted_steps} "
                f"fouls={g.fouls[g.ours]} vs {g.fouls[them]} "
                f"ours={ {k: v for k, v in g.elements[g.ours].items() if v} }"
            )
    result = summarise(records, args.fidelity)
    print(f"bench.game: {args.seeds} seeds, {args.fidelity} fidelity, {args.jobs} job(s)\n")
    result.report(args.results)
    return 1 if args.strict and not result.all_met else 0


def records_as_dicts(records: list[GameRecord]) -> list[dict[str, object]]:
    return [asdict(g) for g in records]


if __name__ == "__main__":
    sys.exit(main())
