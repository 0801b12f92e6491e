"""The error vocabulary of nsrmp-bench.

Every error raised on purpose by the package derives from :class:`NSRMPError`. Each
subclass is something a caller can act on, and every message names the offending value,
what was expected and how to fix it.
"""

from __future__ import annotations

__all__ = [
    "AmbiguousReference",
    "BadProgram",
    "DataIntegrityError",
    "DownloadError",
    "EngineError",
    "GenerationError",
    "InfeasibleStep",
    "InvalidAction",
    "InvalidArgument",
    "InvalidReference",
    "MissingExtra",
    "NSRMPError",
    "PolicyServerError",
    "ResetNeeded",
    "ResourceLimit",
    "SchemaVersionError",
    "SubmissionError",
    "UnknownId",
    "UnsafePath",
]


class NSRMPError(Exception):
    """Base class of every error nsrmp-bench raises on purpose."""


class InvalidArgument(NSRMPError, ValueError):
    """An argument has a value outside the accepted set or range."""


class UnknownId(NSRMPError, KeyError):
    """An id (split, template, baseline, metric, verb ...) is not registered."""

    def __str__(self) -> str:  # KeyError quotes its message; keep it readable.
        return str(self.args[0]) if self.args else ""


class BadProgram(NSRMPError, ValueError):
    """A program does not type-check against the DSL signatures."""


class InvalidReference(NSRMPError):
    """A reference in a program matches no object in the state where it is evaluated."""


class AmbiguousReference(NSRMPError):
    """A reference in a program matches more than one object where it is evaluated."""


class InfeasibleStep(NSRMPError):
    """A manipulation step cannot be carried out (blocked, off the table, degenerate)."""


class GenerationError(NSRMPError):
    """Generation could not produce a valid instance within its bounded number of tries."""


class UnsafePath(NSRMPError, ValueError):
    """A path that arrived from outside (a registry, an archive, a leaderboard entry) is
    absolute, climbs out with ``..`` or leads out through a link: refused, nothing written."""


class ResourceLimit(NSRMPError):
    """An input passed a bound set by what it claims to be (lines, bytes, time), or the
    machine ran out of a resource (disk full, read-only folder, a second writer)."""


class SchemaVersionError(NSRMPError):
    """A file carries a schema version this reader does not understand."""


class DataIntegrityError(NSRMPError):
    """A data file is truncated, corrupt, or disagrees with its manifest."""


class SubmissionError(NSRMPError):
    """A predictions file is malformed; the message names the line and the fix."""


class DownloadError(NSRMPError):
    """A download failed or its content does not match the registered checksum."""


class EngineError(NSRMPError):
    """The engine running the tasks failed: a scheduler unreachable or gone, no workers,
    workers with other versions, a task that kills its workers. Rerunning resumes."""


class MissingExtra(NSRMPError, ImportError):
    """An optional dependency is needed; the message names the extra to install."""


class InvalidAction(NSRMPError, ValueError):
    """An environment action that cannot be carried out as given: a point outside the
    image, an object index the scene does not have, a malformed action."""


class ResetNeeded(NSRMPError, RuntimeError):
    """An environment was stepped before ``reset`` or after its episode ended."""


class PolicyServerError(NSRMPError):
    """The policy server or its client broke the protocol, went silent past the timeout,
    or could not be reached; the message names the peer, the fault and what to do."""
