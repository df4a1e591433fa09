"""The failure every stage reports the same way: a computation that ran and failed a check.

Bad input is a ``ValueError`` raised where the value is first seen (``config.table.ConfigError``,
``config.scene.SceneError``, ``reduced_model.ReducedModelError``): exit status 2. A
:class:`ComputationFailed` carries the numbers that failed: exit status 1.
"""


class ComputationFailed(RuntimeError):
    """A solve, a check or a simulation that did not succeed; the message has the numbers."""


class SceneError(ValueError):
    """A scene that does not fit the body (an unknown group, a joint the group cannot carry)."""
