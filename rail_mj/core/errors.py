"""The project's exception hierarchy.

Every error rail_mj raises derives from :class:`RailError`, so callers can
catch one type. Messages say what was wrong and what is valid or what to do.
"""

from __future__ import annotations

__all__ = [
    "RailError",
    "ConfigError",
    "AffordanceFileError",
    "ProfileFolderError",
    "MeshError",
    "DecompositionError",
    "DecompositionTimeout",
    "FragmentError",
    "SceneError",
    "StablePoseError",
    "ImaginationError",
    "UnknownAffordanceError",
    "LLMError",
    "StageError",
    "ProviderError",
    "UnsafeCodeError",
    "ScoringRuntimeError",
    "DatasetError",
    "RobotError",
    "FolderInUseError",
    "WorkerError",
]


class RailError(Exception):
    """Base class of every error raised by rail_mj."""


class ConfigError(RailError, ValueError):
    """An option or setting has a value that is not allowed."""


class AffordanceFileError(ConfigError):
    """An affordance file (TOML) or a package's ``rail_mj.affordances`` entry point is malformed, or one of its
    rows clashes with a registered affordance; the message names the file (or distribution), the row, the
    field and what is valid."""


class ProfileFolderError(ConfigError):
    """A profile folder in the paper authors' format (rail_mj.profiles) cannot be imported or written; the
    message names the file and what was wrong in it."""


class MeshError(RailError, ValueError):
    """A mesh file cannot be used: unreadable, empty, degenerate or absurd in size."""


class DecompositionError(RailError):
    """Convex decomposition (CoACD) failed or produced no usable hull."""


class DecompositionTimeout(DecompositionError):
    """CoACD ran past ``DecompositionConfig.time_limit_s`` and was stopped."""


class FragmentError(RailError, ValueError):
    """An agent MJCF fragment does not compile or breaks the fragment rules."""


class SceneError(RailError):
    """A MuJoCo scene could not be composed or compiled."""


class StablePoseError(RailError):
    """Stable-pose imagination failed, e.g. the object never settled."""


class ImaginationError(RailError):
    """A batched imagination rollout could not be set up or run."""


class UnknownAffordanceError(RailError, KeyError):
    """The offline provider has no profile for the requested affordance name."""

    def __str__(self) -> str:  # KeyError would otherwise quote the message
        return str(self.args[0]) if self.args else ""


class LLMError(RailError):
    """Base class of the LLM stages' errors."""


class StageError(LLMError):
    """An LLM stage gave no valid answer within its retries."""


class ProviderError(LLMError):
    """The LLM provider failed (network, timeout, authentication, bad reply)."""


class UnsafeCodeError(RailError):
    """Generated scoring code uses a construct outside the allow-list."""


class ScoringRuntimeError(RailError):
    """Generated scoring code failed while running (timeout, crash, bad output)."""


class DatasetError(RailError):
    """A dataset folder or labels file is malformed."""


class RobotError(RailError):
    """The robot model could not be obtained or an execution could not be set up."""


class FolderInUseError(RailError):
    """Another live process holds an output folder's lock (e.g. a second eval run on one ``--out``).

    The message names the holder (pid, host, start time, command). CLI exit status 1, not 2: the
    command line is valid (the same command succeeds once the holder has ended), and 2 would tell a
    script to change it; nothing was written.
    """


class WorkerError(RailError):
    """A worker process of a parallel or Ray run died (a crash in native code, the OOM killer, a kill) while on
    an object: that object's cases become error results and the run goes on. Raised, stopping the run, only
    when no worker process can be started at all.
    """
