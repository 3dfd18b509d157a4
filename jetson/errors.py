"""Every error the Jetson side raises: one hierarchy under JetsonError.

Each names what is wrong and, where it can, what to do. They are RuntimeErrors so that
`pete-jetson` prints any of them as one line instead of a traceback; those about a bad value
are ValueErrors too.
"""

from __future__ import annotations


class JetsonError(RuntimeError):
    """Base of every error raised by the jetson package."""


class SettingsError(JetsonError, ValueError):
    """A daemon setting (the TOML settings file or a command-line flag) that cannot be used."""


class ObservationError(JetsonError, ValueError):
    """Bad input to the observation builder, or an observation spec that cannot be used."""


class PolicyError(JetsonError, ValueError):
    """A policy file that cannot be loaded, or an input it cannot take, named with the reason."""


class ReplayError(JetsonError):
    """A session recording that cannot be replayed."""


class PerceptionError(JetsonError):
    """Base of every perception error."""


class SourceError(PerceptionError):
    """A camera, recording or stream that cannot be opened or read."""


class DatasetError(PerceptionError):
    """A dataset folder that is missing, empty or malformed."""


class ModelError(PerceptionError):
    """Detector weights that are missing or unusable."""


class CameraProcessError(PerceptionError):
    """The camera's own process could not start: its pipeline's error (a missing model, a bad
    camera config) as the camera thread would have raised it."""


class CameraConfigError(PerceptionError):
    """A camera model value or camera config file that cannot be used."""


class CalibrationError(PerceptionError):
    """Calibration images that do not yield a camera model."""
