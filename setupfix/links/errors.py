"""Errors of a machine link, under :class:`setupfix.core.errors.SetupfixError`.

Each class carries the exit status of ``../shared/spec/machine-link.md`` in ``exit_status``
(the CLI's error boundary returns it): 1 bad input, 6 refused before any write, 7 written but
not confirmed, 8 the control could not be reached.  Messages name the link file (or the
endpoint) and the register component; they never hold a password.
"""

from __future__ import annotations

from setupfix.core.errors import SetupfixError

__all__ = [
    "EXIT_REFUSED",
    "EXIT_UNCONFIRMED",
    "EXIT_UNREACHABLE",
    "LinkError",
    "LinkConfigError",
    "LinkUnreachable",
    "LinkLost",
    "LinkDenied",
    "LinkRefused",
    "LinkUnconfirmed",
]

#: Refused before any write: stale table, interlock, limit, a verdict that is not ``apply``.
EXIT_REFUSED = 6
#: Written but not confirmed: rolled back, or the roll-back itself failed ("CHECK THE CONTROL").
EXIT_UNCONFIRMED = 7
#: The control could not be reached: nothing written.
EXIT_UNREACHABLE = 8


class LinkError(SetupfixError):
    """Anything that goes wrong talking to a control (exit status 1 unless a subclass says otherwise)."""

    exit_status: int = 1


class LinkConfigError(LinkError, ValueError):
    """The link file is invalid, or a register component the model needs is not mapped (file and key named)."""


class LinkUnreachable(LinkError, ConnectionError):
    """The control did not answer (connection refused, timeout, bad endpoint): nothing was written."""

    exit_status = EXIT_UNREACHABLE


class LinkLost(LinkError, ConnectionError):
    """The connection dropped in the middle of an exchange (a write may be partly done)."""

    exit_status = EXIT_UNCONFIRMED


class LinkDenied(LinkError, PermissionError):
    """The control refused access to a node (OPC UA ``BadUserAccessDenied``, a read-only node)."""


class LinkRefused(LinkError):
    """setupfix refuses to write: stale table, interlock, limit, verdict (nothing written)."""

    exit_status = EXIT_REFUSED


class LinkUnconfirmed(LinkError):
    """Written but not confirmed by the read-back; rolled back, or the roll-back failed."""

    exit_status = EXIT_UNCONFIRMED
