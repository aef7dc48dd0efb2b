"""Which store locations are server URLs, how they are read, and how they may be printed.

Anything that looks like a URL is one (:func:`looks_like_url`): a ``postgres``/``postgresql``
scheme in any case, with one, two or no slashes, with spaces around it, and any other
``scheme://``.  It is read here (:func:`parse_url`), never taken as a file path, and it is
printed only as :func:`shown` gives it: scheme, user, host, port and database -- never the
password, nor the query (which may hold one).

The password is what lies between the first ``:`` of the user part and the LAST ``@``: a
password typed without percent-encoding (holding ``@``, ``:``, ``/``, ``#``, ``?`` or ``%``)
is still read whole, so no piece of it is ever taken for a host, port or database name (which
the driver would then quote in its messages); :func:`urllib.parse.urlsplit` ends the user part at
the first ``/``, ``?`` or ``#``, so it cannot read such a password, hence this reader.  The parts are
given to the driver one by one
(:meth:`ServerURL.connection`), so it never parses the text itself.

A URL that cannot be read (another scheme, a missing ``//``, a port that is not a number, a
``#`` after the host) is refused with :class:`~setupfix.core.errors.StoreError`, naming it as
:func:`shown` does.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from urllib.parse import parse_qsl, unquote

from setupfix.core.errors import SourceLocation, StoreError

__all__ = ["ServerURL", "looks_like_url", "parse_url", "shown", "SCHEMES", "URL_FORM"]

#: The schemes of a PostgreSQL URL (in any case).
SCHEMES = ("postgresql", "postgres")
#: How a server URL is written (the hint of a refusal).
URL_FORM = "postgresql://user:password@host:port/database"

_LIKE = re.compile(r"\s*(?:postgres(?:ql)?\s*:|[A-Za-z][A-Za-z0-9+.\-]+://)", re.IGNORECASE)
_SCHEME = re.compile(r"\s*([A-Za-z][A-Za-z0-9+.\-]*)\s*:(.*)", re.DOTALL)


def looks_like_url(location: object) -> bool:
    """Whether ``location`` is a URL (a server store, or a malformed URL to refuse), not a file path."""
    return bool(_LIKE.match(str(location)))


@dataclass(frozen=True)
class _Pieces:
    scheme: str
    slashes: int
    user: str | None
    password: str | None
    netloc: str
    path: str
    query: str
    fragment: str


def _pieces(text: str) -> _Pieces:
    """The parts of a URL-like text, the password being all between the user's ``:`` and the last ``@``."""
    found = _SCHEME.match(text.strip())
    scheme, rest = (found.group(1).lower(), found.group(2).strip()) if found else ("", text.strip())
    bare = rest.lstrip("/")
    slashes = len(rest) - len(bare)
    user = password = None
    if "@" in bare:
        userinfo, _, bare = bare.rpartition("@")
        user, colon, secret = userinfo.partition(":")
        password = secret if colon else None
    bare, _, fragment = bare.partition("#")
    bare, _, query = bare.partition("?")
    netloc, _, path = bare.partition("/")
    return _Pieces(scheme, slashes, user, password, netloc, path, query, fragment)


def _host_port(netloc: str) -> tuple[str, str | None]:
    """(host, port) of ``host``, ``host:port``, ``[v6]:port``; port "" when absent, None when not a number
    (or a ``[`` is not closed).

    Several hosts (``h1:p1,h2:p2``) keep their list, as the driver takes it.
    """
    hosts, ports = [], []
    for one in netloc.split(","):
        if one.startswith("[") and "]" not in one:
            return one, None
        if one.startswith("["):
            host, _, tail = one[1:].partition("]")
            port = tail[1:] if tail.startswith(":") else (tail or "")
        elif one.count(":") == 1:
            host, _, port = one.partition(":")
        else:
            host, port = one, ""
        hosts.append(host)
        ports.append(port)
    if any(p and not p.isdigit() for p in ports):
        return ",".join(hosts), None
    return ",".join(hosts), ",".join(ports) if any(ports) else ""


def shown(location: str) -> str:
    """``location`` as it may be printed: a URL-like one without its password and query; a path as it is."""
    if not looks_like_url(location):
        return str(location)
    p = _pieces(str(location))
    host, port = _host_port(p.netloc)
    if port is None:
        netloc = host if host.startswith("[") else f"{host}:…"
    else:
        netloc = ("[" + host + "]" if ":" in host else host) + (f":{port}" if port else "")
    user = f"{p.user}@" if p.user else ""
    return f"{p.scheme or 'postgresql'}://{user}{netloc}" + (f"/{p.path}" if p.path else "")


@dataclass(frozen=True)
class ServerURL:
    """A PostgreSQL URL read into its parts (percent-decoded); ``shown`` is how it may be printed."""

    shown: str
    host: str
    port: str
    user: str | None
    password: str | None
    dbname: str
    options: tuple[tuple[str, str], ...]

    def connection(self) -> dict[str, str]:
        """The driver's keyword arguments (the query's options, then the parts given)."""
        given = dict(self.options)
        for key in ("host", "port", "user", "password", "dbname"):
            value = getattr(self, key)
            if value:
                given[key] = value
        return given


def parse_url(text: str) -> ServerURL:
    """Read a server URL (any case of its scheme, spaces around it ignored).

    Raises
    ------
    StoreError
        Naming the URL as :func:`shown` prints it: not a PostgreSQL scheme, no ``//`` after the
        scheme, a port that is not a number, a ``#`` after the host.
    """
    p = _pieces(text)
    where = SourceLocation(shown(text))

    def refuse(why: str) -> StoreError:
        return StoreError(f"not a PostgreSQL URL setupfix can read ({why})", location=where, hint=URL_FORM)

    if p.scheme not in SCHEMES:
        raise refuse(f"the scheme is {p.scheme!r}, not postgresql" if p.scheme else "no postgresql:// scheme")
    if p.slashes != 2:
        raise refuse(f"{p.scheme}: is followed by {p.slashes} slash(es), not //")
    if p.fragment:
        raise refuse("a '#' after the host; a '#' in the password is read when an '@' follows it")
    host, port = _host_port(unquote(p.netloc))
    if port is None:
        raise refuse("a '[' not closed" if host.startswith("[") else "the port is not a number")
    try:
        options = tuple(parse_qsl(p.query, keep_blank_values=True, strict_parsing=bool(p.query)))
    except ValueError:
        raise refuse("its options after '?' are not name=value pairs") from None
    return ServerURL(
        shown=where.path,
        host=host,
        port=port,
        user=unquote(p.user) if p.user is not None else None,
        password=unquote(p.password) if p.password is not None else None,
        dbname=unquote(p.path),
        options=options,
    )
