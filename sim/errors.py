"""Every error the simulator raises: one hierarchy under SimError.

SimError is a RuntimeError, so the command-line tools print any of them as one line (`pete-sim`
catches them and says what went wrong). An error that names a value that cannot be used is a
ValueError too, as it was before there was one hierarchy, so `except ValueError` still catches it.
"""

from __future__ import annotations


class SimError(RuntimeError):
    """Something in the simulator cannot go on; the message says what."""


class ConfigError(SimError, ValueError):
    """A configuration value that cannot be used, named."""


class FieldError(SimError, ValueError):
    """A field file that cannot be used, with the file and key named."""


class WorldError(SimError):
    """Misuse of the world (wrong number of commands, stepping before reset, ...)."""


class WorkerError(SimError):
    """A rollout worker failed; the message carries its traceback."""


class ClusterError(SimError):
    """Ray is not installed, a Ray cluster cannot be reached, or it could not run the work sent
    to it; the message says which and what to do."""


class CheckpointError(SimError, ValueError):
    """A checkpoint that cannot be written or is refused on loading (not ours, or unsafe), named."""


class EvalError(SimError, ValueError):
    """A player that cannot be loaded or an evaluation that cannot run, named."""


class OriginalPolicyError(SimError, ValueError):
    """The file is not the original policy (or not usable), named."""


class MatchError(SimError, ValueError):
    """Options that cannot make a match, or a stack that could not be started, named."""


class BrainHostError(SimError):
    """brain_host refused a command, died, or stopped answering; the message says which."""


class CableError(SimError):
    """Bytes a side said it wrote never arrived."""


class DaemonError(SimError):
    """The in-process daemon could not be built or stopped keeping up."""
