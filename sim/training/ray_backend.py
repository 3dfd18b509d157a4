"""Rollouts and evaluation on a Ray cluster: Ray places the work and moves the data, not us.

    with RayBackend("auto") as ray_backend:               # or "host:6379", "ray://host:10001"
        vec = VecMatches(env, rollout, seed=1, launcher=ray_backend.launch)
        summary = evaluate(ours, planner, 20, seed=0, runner=ray_backend.play)

What is ours here is a wrapper and nothing more:

- a rollout worker is a Ray actor holding one `MatchGroup` (sim.training.rollout), the very class a
  worker process holds, so the same seeds give the same StepResults on a cluster as on this
  machine; `VecMatches` calls its methods in lockstep through `RayWorkers`. The actors ask for one
  CPU each and Ray spreads them over the cluster's nodes (the SPREAD strategy);
- an evaluation match is a Ray task: a seed's pair of matches (sides swapped) per task, played by
  `sim.evaluate.Series.play`, so the records are those a local evaluation gives.

The self-play league rides on the rollouts: the pool's snapshots act in the training process,
which sends each step's opponent actions to the actors with the learner's.

Ray is an optional extra (`pip install -e .[ray]`): nothing here imports it until a backend is
opened, and a missing extra, or an address where no cluster answers, is a ClusterError saying
what to do, not a hang (Ray itself retries an unreachable address for minutes).
"""

from __future__ import annotations

import contextlib
import socket
from collections.abc import Callable, Sequence
from types import ModuleType, TracebackType
from typing import Any

from sim.errors import ClusterError, EvalError, WorkerError
from sim.evaluate import MatchRecord, Series
from sim.training.rollout import GroupSpec, MatchGroup

INSTALL_HINT = "pip install -e .[ray] in a checkout, or pip install 'pacman-pete[ray]'"
PROBE_TIMEOUT_S = 5.0
CLOSE_TIMEOUT_S = 10.0
MATCHES_PER_TASK = 2  # one seed, sides swapped


def require_ray(what: str = "--ray") -> ModuleType:
    """The ray module, or a ClusterError that says how to install it."""
    try:
        import ray
    except ModuleNotFoundError as e:
        raise ClusterError(f"{what} needs the ray extra: {INSTALL_HINT}") from e
    return ray


def _host_port(address: str) -> tuple[str, int] | None:
    """(host, port) of a `host:port` or `ray://host:port` address; None for auto and local."""
    if address in ("auto", "local"):
        return None
    rest = address.removeprefix("ray://")
    host, sep, port = rest.rpartition(":")
    if not sep or not host or not port.isdigit():
        raise ClusterError(
            f"Ray address {address!r}: expected host:port of the cluster's head (what `ray start "
            "--head` prints), ray://host:port (Ray Client), auto (the cluster this machine "
            "joined) or local (a Ray started here)"
        )
    return host.strip("[]"), int(port)


def probe(address: str, timeout_s: float = PROBE_TIMEOUT_S) -> None:
    """Fail fast when nothing listens at a host:port address (ray.init would retry for
    minutes)."""
    where = _host_port(address)
    if where is None:
        return
    try:
        with socket.create_connection(where, timeout=timeout_s):
            pass
    except OSError as e:
        raise ClusterError(
            f"no Ray cluster answers at {address} ({e.strerror or e}): start its head with "
            "`ray start --head` on that machine (it prints the address to join), or use "
            "--ray local for a one-machine Ray here"
        ) from e


class GroupActor(MatchGroup):
    """A rollout worker as a Ray actor: a MatchGroup that can also say where it runs."""

    def node(self) -> str:
        import ray

        return str(ray.get_runtime_context().get_node_id())


class RayWorkers:
    """VecMatches' workers as Ray actors, one MatchGroup each (rollout.Workers)."""

    def __init__(self, ray: ModuleType, specs: list[GroupSpec]) -> None:
        self._ray = ray
        actor = ray.remote(GroupActor).options(
            num_cpus=1, scheduling_strategy="SPREAD", max_restarts=0
        )
        self._actors: list[Any] = [
            actor.remote(s.config, s.rollout, s.seed, s.first_slot, s.count, s.teacher)
            for s in specs
        ]
        # Waits for every actor's matches to be built; a failure there surfaces now.
        self.nodes: list[str] = self._get([a.node.remote() for a in self._actors])

    def _get(self, refs: list[Any]) -> list[Any]:
        try:
            return list(self._ray.get(refs))
        except self._ray.exceptions.RayError as e:
            self.close()
            raise WorkerError(f"a rollout actor failed:\n{e}") from e

    def call(self, method: str, args: Sequence[tuple[Any, ...]]) -> list[Any]:
        calls = zip(self._actors, args, strict=True)
        return self._get([getattr(a, method).remote(*x) for a, x in calls])

    def close(self) -> None:
        ray, actors = self._ray, self._actors
        self._actors = []
        if not actors:
            return
        with contextlib.suppress(ray.exceptions.RayError):  # a dead actor has nothing to close
            ray.get([a.close.remote() for a in actors], timeout=CLOSE_TIMEOUT_S)
        for a in actors:
            ray.kill(a)


def play_matches(series: Series, ks: list[int]) -> list[MatchRecord]:
    """The body of an evaluation task: matches ks of the series."""
    return series.play(ks)


class RayBackend:
    """A connection to a Ray cluster for the trainer and evaluation; a context manager.

    address: `host:port` of the head, `ray://host:port` (Ray Client), `auto` (the cluster this
    machine joined) or `local` (a Ray started here for the duration). A process already connected
    (ray.init called before) keeps its connection, and it is not shut down on exit.
    """

    def __init__(self, address: str) -> None:
        self.address = address
        self._ray: ModuleType | None = None
        self._owned = False
        self.nodes: list[str] = []  # the nodes of the last launched rollout actors

    def __enter__(self) -> RayBackend:
        ray = require_ray()
        if not ray.is_initialized():
            probe(self.address)
            try:
                ray.init(address=None if self.address == "local" else self.address)
            except (ConnectionError, ValueError, RuntimeError) as e:
                raise ClusterError(f"could not join the Ray cluster at {self.address}: {e}") from e
            self._owned = True
        self._ray = ray
        return self

    def __exit__(
        self,
        kind: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        if self._ray is not None and self._owned:
            self._ray.shutdown()
        self._ray, self._owned = None, False

    @property
    def ray(self) -> ModuleType:
        if self._ray is None:
            raise ClusterError("the Ray backend is not open: use it as `with RayBackend(...)`")
        return self._ray

    def cpus(self) -> float:
        """The cluster's CPUs, as Ray counts them."""
        return float(self.ray.cluster_resources().get("CPU", 0.0))

    def launch(self, specs: list[GroupSpec]) -> RayWorkers:
        """Rollout workers as actors (VecMatches' launcher)."""
        workers = RayWorkers(self.ray, specs)
        self.nodes = list(workers.nodes)
        return workers

    def play(
        self, series: Series, matches: int, progress: Callable[[int, int], None] | None = None
    ) -> list[MatchRecord]:
        """Matches 0 ... matches - 1 of `series` as Ray tasks (evaluate's runner), in order."""
        ray = self.ray
        task = ray.remote(play_matches).options(num_cpus=1, scheduling_strategy="SPREAD")
        shared = ray.put(series)
        pending = {
            task.remote(shared, ks): ks
            for ks in (
                list(range(k, min(k + MATCHES_PER_TASK, matches)))
                for k in range(0, matches, MATCHES_PER_TASK)
            )
        }
        found: dict[int, MatchRecord] = {}
        try:
            while pending:
                done, _ = ray.wait(list(pending), num_returns=1)
                for ref in done:
                    found.update(zip(pending.pop(ref), ray.get(ref), strict=True))
                if progress is not None:
                    progress(len(found), matches)
        except EvalError:
            raise  # a task's EvalError arrives as one (Ray keeps the type)
        except ray.exceptions.RayError as e:
            raise ClusterError(f"an evaluation task failed:\n{e}") from e
        finally:
            for ref in pending:
                ray.cancel(ref)
        return [found[k] for k in range(matches)]

    def describe(self) -> str:
        """One line: the cluster and where the last rollout actors run."""
        ray = self.ray
        nodes = [n for n in ray.nodes() if n.get("Alive")]
        line = f"Ray at {self.address}: {len(nodes)} node(s), {self.cpus():.0f} CPUs"
        if self.nodes:
            line += f"; {len(self.nodes)} rollout actors on {len(set(self.nodes))} node(s)"
        return line
