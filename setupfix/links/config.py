"""The link file (``../shared/spec/machine-link.md``, "The link file"): one TOML per machine.

``[link]`` holds the protocol, the endpoint, the control's unit and increment, the credentials
(the password comes from the environment variable ``password_env`` names, read here and held
outside the repr: never printed, logged or stored), the security string, the timeout, the
interlock node and the machine name.  ``[registers."G54"]`` tables map each register component
(``X`` … ``C``, ``length``, ``radius``) to an OPC UA node id.  Every error names the file and key.
"""

from __future__ import annotations

import dataclasses
import math
import os
import re
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from setupfix.core.errors import SourceLocation
from setupfix.core.units import normalise_unit
from setupfix.links.base import TOOL_AXES, WKS_AXES, Component
from setupfix.links.errors import LinkConfigError

__all__ = ["LinkConfig", "Security", "load_link", "NODE_ID", "PROTOCOLS", "LINK_KEYS"]

#: Protocols a link file may name (a registry entry in :data:`setupfix.links.LINKS` each).
PROTOCOLS = ("opcua", "linuxcnc")
#: Keys of the ``[link]`` table.
LINK_KEYS = frozenset(
    {
        "protocol",
        "endpoint",
        "unit",
        "increment",
        "user",
        "password_env",
        "security",
        "timeout",
        "interlock",
        "machine",
        "ini",
    }
)
#: An OPC UA node id as the standard writes it: ``ns=2;s=…``, ``ns=3;i=1042``, ``nsu=<uri>;s=…``, ``i=85``.
NODE_ID = re.compile(r"^(?:(?:ns=\d+|nsu=[^;]+);)?(?:s=.+|i=\d+|g=[0-9A-Fa-f-]{36}|b=[A-Za-z0-9+/=]+)$")
POLICIES = ("Basic256Sha256", "Aes128Sha256RsaOaep", "Aes256Sha256RsaPss")
MODES = ("Sign", "SignAndEncrypt")


@dataclass(frozen=True)
class Security:
    """``security = "Policy,Mode,cert,key"``: the policy, the mode and the client's certificate and key (paths)."""

    policy: str
    mode: str
    certificate: str
    private_key: str
    server_certificate: str | None = None

    @property
    def encrypted(self) -> bool:
        return self.mode == "SignAndEncrypt"

    def asyncua_string(self) -> str:
        """The form ``asyncua.Client.set_security_string`` takes."""
        parts = [self.policy, self.mode, self.certificate, self.private_key]
        return ",".join(parts + ([self.server_certificate] if self.server_certificate else []))


@dataclass(frozen=True)
class LinkConfig:
    """A link file, validated.  ``password`` is not in the repr and never leaves the link."""

    path: str
    protocol: str
    endpoint: str | None = None
    unit: str = "mm"
    increment: float = 0.001
    user: str | None = None
    password_env: str | None = None
    password: str | None = field(default=None, repr=False, compare=False)
    security: Security | None = None
    timeout: float = 5.0
    interlock: str | None = None
    machine: str | None = None
    ini: str | None = None
    nodes: tuple[tuple[Component, str], ...] = ()
    insecure: bool = False

    @property
    def node_map(self) -> dict[Component, str]:
        return dict(self.nodes)

    @property
    def name(self) -> str:
        """For messages: the endpoint (or INI) and the file; never a secret."""
        where = self.endpoint or self.ini or self.protocol
        return f"{_without_userinfo(where)} ({self.path})"

    def where(self, key: str | None = None) -> SourceLocation:
        return SourceLocation(self.path, key=key)

    def with_insecure(self, insecure: bool) -> LinkConfig:
        """The same link, allowed (or not) to send a password over an unencrypted session."""
        return dataclasses.replace(self, insecure=insecure)


def _without_userinfo(endpoint: str) -> str:
    """``opc.tcp://user:pw@host`` without the ``user:pw@`` part (a secret in a URL is never shown)."""
    return re.sub(r"^([a-z.]+://)[^/@]*@", r"\1", endpoint)


def load_link(path: str | Path, *, environ: Mapping[str, str] | None = None) -> LinkConfig:
    """Read and validate a link file.

    Raises
    ------
    LinkConfigError
        Naming the file and key: unreadable file or TOML, an unknown key or protocol, a value of
        the wrong type or range, a bad node id, a component the register cannot have, a missing
        password variable, a security file that does not exist.
    """
    name = str(path)
    env = os.environ if environ is None else environ
    try:
        text = Path(path).read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise LinkConfigError(f"cannot read the link file: {exc}", location=SourceLocation(name)) from None
    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise LinkConfigError(f"not a valid TOML file: {exc}", location=SourceLocation(name)) from None
    unknown = sorted(set(doc) - {"link", "registers"})
    if unknown:
        raise LinkConfigError("unknown table (known: link, registers)", location=SourceLocation(name, key=unknown[0]))
    table = doc.get("link")
    if not isinstance(table, dict):
        raise LinkConfigError("a link file needs its [link] table", location=SourceLocation(name, key="link"))
    extra = sorted(set(table) - LINK_KEYS)
    if extra:
        raise LinkConfigError(
            f"unknown key (known: {', '.join(sorted(LINK_KEYS))})",
            location=SourceLocation(name, key=f"link.{extra[0]}"),
        )

    def where(key: str) -> SourceLocation:
        return SourceLocation(name, key=f"link.{key}")

    def text_of(key: str, required: bool = False) -> str | None:
        value = table.get(key)
        if value is None:
            if required:
                raise LinkConfigError("required", location=where(key))
            return None
        if not isinstance(value, str) or not value.strip():
            raise LinkConfigError("expected a non-empty string", location=where(key))
        return value.strip()

    def positive(key: str, default: float) -> float:
        value = table.get(key, default)
        if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value) or value <= 0:
            raise LinkConfigError(f"expected a number > 0, found {value!r}", location=where(key))
        return float(value)

    protocol = text_of("protocol", required=True)
    assert protocol is not None
    if protocol not in PROTOCOLS:
        raise LinkConfigError(
            f"unknown protocol {protocol!r} (known: {', '.join(PROTOCOLS)})", location=where("protocol")
        )
    endpoint = text_of("endpoint", required=protocol == "opcua")
    if endpoint is not None and protocol == "opcua" and not endpoint.startswith("opc.tcp://"):
        raise LinkConfigError("expected an opc.tcp:// endpoint", location=where("endpoint"))
    unit_text = text_of("unit") or "mm"
    try:
        unit = normalise_unit(unit_text)
    except KeyError:
        raise LinkConfigError(f"expected mm or inch, found {unit_text!r}", location=where("unit")) from None
    increment = positive("increment", 0.001)
    if increment > 1.0:
        raise LinkConfigError(f"an increment of {increment:g} {unit} is no control's", location=where("increment"))
    timeout = positive("timeout", 5.0)
    user = text_of("user")
    password_env = text_of("password_env")
    password = None
    if password_env is not None:
        password = env.get(password_env)
        if password is None:
            raise LinkConfigError(f"the environment variable {password_env} is not set", location=where("password_env"))
    if user is None and password_env is not None:
        raise LinkConfigError("password_env without user", location=where("password_env"))
    base = Path(path).parent
    security = _security(text_of("security"), base, where("security"))
    interlock = text_of("interlock")
    if interlock is not None and protocol == "opcua" and not NODE_ID.match(interlock):
        raise LinkConfigError(f"not an OPC UA node id: {interlock!r}", location=where("interlock"))
    ini = text_of("ini", required=protocol == "linuxcnc")
    if ini is not None and not Path(ini).is_absolute():
        ini = str(base / ini)
    nodes = _registers(doc.get("registers", {}), name, protocol)
    return LinkConfig(
        path=name,
        protocol=protocol,
        endpoint=endpoint,
        unit=unit,
        increment=increment,
        user=user,
        password_env=password_env,
        password=password,
        security=security,
        timeout=timeout,
        interlock=interlock,
        machine=text_of("machine"),
        ini=ini,
        nodes=nodes,
    )


def _security(text: str | None, base: Path, where: SourceLocation) -> Security | None:
    if text is None:
        return None
    parts = [p.strip() for p in text.split(",")]
    if len(parts) not in (4, 5):
        raise LinkConfigError(
            "expected 'Policy,Mode,certificate,private key' (e.g. Basic256Sha256,SignAndEncrypt,cert.pem,key.pem)",
            location=where,
        )
    policy, mode, *files = parts
    if policy not in POLICIES:
        raise LinkConfigError(f"unknown security policy {policy!r} (known: {', '.join(POLICIES)})", location=where)
    if mode not in MODES:
        raise LinkConfigError(f"unknown security mode {mode!r} (known: {', '.join(MODES)})", location=where)
    paths = []
    for f in files:
        p = Path(f) if Path(f).is_absolute() else base / f
        if not p.is_file():
            raise LinkConfigError(f"no such file: {p}", location=where)
        paths.append(str(p))
    return Security(policy, mode, paths[0], paths[1], paths[2] if len(paths) == 3 else None)


def _axis(key: str) -> str | None:
    """The component a ``[registers.G54]`` key names (``x`` → ``X``), or None."""
    if key.lower() in TOOL_AXES:
        return key.lower()
    return key.upper() if key.upper() in WKS_AXES else None


def _registers(table: Any, name: str, protocol: str) -> tuple[tuple[Component, str], ...]:
    if not isinstance(table, dict):
        raise LinkConfigError('expected tables [registers."G54"]', location=SourceLocation(name, key="registers"))
    out: list[tuple[Component, str]] = []
    for register, comps in table.items():
        key = f"registers.{register}"
        if not isinstance(comps, dict) or not comps:
            raise LinkConfigError("expected a table of component = node id", location=SourceLocation(name, key=key))
        kinds = set()
        for comp, node in comps.items():
            where = SourceLocation(name, key=f"{key}.{comp}")
            axis = _axis(str(comp))
            if axis is None:
                raise LinkConfigError(f"unknown component (known: {', '.join(WKS_AXES + TOOL_AXES)})", location=where)
            kinds.add(axis in TOOL_AXES)
            if not isinstance(node, str) or (protocol == "opcua" and not NODE_ID.match(node.strip())):
                raise LinkConfigError(f"not an OPC UA node id: {node!r}", location=where)
            out.append((Component(str(register), axis), node.strip()))
        if len(kinds) > 1:
            raise LinkConfigError(
                "a register is a work offset (X, Y, Z, C) or a tool register (length, radius), not both",
                location=SourceLocation(name, key=key),
            )
    return tuple(out)
