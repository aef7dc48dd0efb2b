"""A test control: an asyncua OPC UA server on a loopback port that behaves like a machine's offset table.

It models what real controls do to the values a client writes (``../shared/spec/machine-link.md``):

- every value is stored at the control's increment (in the control's unit: mm or inch);
- a wear register is clamped by the control to its range (``clamp``), silently;
- while a program runs (``running``), writes are ignored, and the interlock node reads true;
- read-only nodes answer ``BadUserAccessDenied`` (the session is a plain user, not admin);
- ``stop_after(n)``: the server stops after the next ``n`` writes (the connection is lost mid-write),
  and ``restart()`` brings it back on the same port with the values it held.

The server runs in its own thread with its own event loop; the test talks to it through plain methods.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import math
import socket
import threading
from collections.abc import Coroutine, Iterator, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TypeVar

from asyncua import ua
from asyncua.crypto.permission_rules import User, UserRole
from asyncua.server.address_space import NodeData
from asyncua.server.server import Server
from asyncua.server.user_managers import UserManager

__all__ = ["ControlSpec", "TestControl", "running_control", "free_port", "NAMESPACE"]

T = TypeVar("T")
NAMESPACE = "urn:setupfix:test-control"
#: The user a password-protected control accepts.
USER = "setter"


def make_certificate(folder: Path, name: str, uri: str) -> tuple[str, str]:
    """A self-signed application certificate (DER) and its key (PEM) for ``uri`` on 127.0.0.1."""
    from asyncua.crypto.cert_gen import setup_self_signed_certificate
    from cryptography.x509.oid import ExtendedKeyUsageOID

    cert, key = folder / f"{name}.der", folder / f"{name}-key.pem"
    uses = [ExtendedKeyUsageOID.SERVER_AUTH, ExtendedKeyUsageOID.CLIENT_AUTH]
    asyncio.run(setup_self_signed_certificate(key, cert, uri, "127.0.0.1", uses, {"commonName": name}))
    return str(cert), str(key)


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


@dataclass
class ControlSpec:
    """The table: path → value (control unit), with the clamped ranges and the read-only paths."""

    values: dict[str, float]
    increment: float = 0.001
    increments: dict[str, float] = field(default_factory=dict)  # a path's own increment (an inch channel)
    clamp: dict[str, tuple[float, float]] = field(default_factory=dict)
    read_only: frozenset[str] = frozenset()
    password: str | None = None
    #: The server's certificate and key (PEM): then it offers only Basic256Sha256 SignAndEncrypt.
    certificate: tuple[str, str] | None = None


class _Users(UserManager):
    """Every session is a plain user (so access levels hold); with a password only the right one enters."""

    def __init__(self, password: str | None) -> None:
        self.password = password
        self.seen: list[tuple[str | None, str | None]] = []

    def get_user(
        self, iserver: Any, username: str | None = None, password: str | None = None, certificate: Any = None
    ) -> User | None:
        self.seen.append((username, password))
        if self.password is not None and (username != USER or password != self.password):
            return None
        return User(role=UserRole.User, name=username)


class TestControl:
    """See the module docstring.  ``node(path)`` is the node id string a link file maps."""

    __test__ = False  # not a pytest class

    def __init__(self, spec: ControlSpec, port: int | None = None) -> None:
        self.spec = spec
        self.port = port or free_port()
        self.endpoint = f"opc.tcp://127.0.0.1:{self.port}"
        self.values: dict[str, float] = {k: self._grid(v, k) for k, v in spec.values.items()}
        self.running = False
        self.writes: list[tuple[str, float]] = []  # every write the control accepted (path, stored value)
        self._stop_after: int | None = None
        self._restart = False
        self._loop = asyncio.new_event_loop()
        self._thread = threading.Thread(target=self._loop.run_forever, daemon=True, name="test-control")
        self._thread.start()
        self._server: Server | None = None
        self._ns = 2
        self.users = _Users(spec.password)
        logging.getLogger("asyncua").setLevel(
            logging.CRITICAL if not __import__("os").environ.get("H1DBG") else logging.WARNING
        )

    # -- plumbing ----------------------------------------------------------------------------
    def _call(self, coro: Coroutine[Any, Any, T]) -> T:
        return asyncio.run_coroutine_threadsafe(coro, self._loop).result(timeout=30)

    def node(self, path: str) -> str:
        return f"ns={self._ns};s={path}"

    def _grid(self, value: float, path: str = "") -> float:
        inc = self.spec.increments.get(path, self.spec.increment)
        digits = max(0, -math.floor(math.log10(inc))) + 2
        return round(round(value / inc) * inc, digits) + 0.0

    # -- lifecycle ---------------------------------------------------------------------------
    def start(self) -> None:
        self._call(self._start())

    async def _start(self) -> None:
        server = Server(user_manager=self.users)
        await server.init()
        server.set_endpoint(self.endpoint)
        if self.spec.certificate is not None:
            server.set_security_policy([ua.SecurityPolicyType.Basic256Sha256_SignAndEncrypt])
            await server.load_certificate(self.spec.certificate[0])
            await server.load_private_key(self.spec.certificate[1])
        else:
            server.set_security_policy([ua.SecurityPolicyType.NoSecurity])
        server.set_identity_tokens([ua.AnonymousIdentityToken, ua.UserNameIdentityToken])
        self._ns = await server.register_namespace(NAMESPACE)
        objects = server.nodes.objects
        folder = await objects.add_folder(ua.NodeId.from_string(f"ns={self._ns};s=Offsets"), "Offsets")
        for path, value in self.values.items():
            var = await folder.add_variable(
                ua.NodeId.from_string(f"ns={self._ns};s={path}"), path, float(value), varianttype=ua.VariantType.Double
            )
            if path not in self.spec.read_only:
                await var.set_writable(True)
            server.set_attribute_value_setter(var.nodeid, self._setter(path))
        interlock = await folder.add_variable(ua.NodeId.from_string(f"ns={self._ns};s=Interlock"), "Interlock", False)
        server.set_attribute_value_callback(
            interlock.nodeid, lambda nid, attr: ua.DataValue(ua.Variant(self.running, ua.VariantType.Boolean))
        )
        for path in self.values:
            var_id = ua.NodeId.from_string(f"ns={self._ns};s={path}")
            server.set_attribute_value_callback(var_id, self._getter(path))
        await server.start()
        self._server = server

    def _getter(self, path: str) -> Any:
        def get(nid: ua.NodeId, attr: Any) -> ua.DataValue:
            return ua.DataValue(ua.Variant(self.values[path], ua.VariantType.Double))

        return get

    def _setter(self, path: str) -> Any:
        def set_(node: NodeData, attr: Any, dv: ua.DataValue) -> None:
            if self.running:  # a program runs: the control ignores offset writes
                return
            if self._stop_after is not None and self._stop_after <= 0:
                # the write after the last one kept: the control goes away instead (the client has read the
                # answers to the writes before, since it sent this one only after them)
                self._stop_after = None
                self._loop.create_task(self._bounce() if self._restart else self._stop())
                return
            value = float(dv.Value.Value) if dv.Value is not None else math.nan
            low, high = self.spec.clamp.get(path, (-math.inf, math.inf))
            self.values[path] = self._grid(min(max(value, low), high), path)
            self.writes.append((path, self.values[path]))
            if self._stop_after is not None:
                self._stop_after -= 1

        return set_

    def stop_after(self, writes: int, *, restart: bool = False) -> None:
        """Keep the next ``writes`` writes, then stop the server when the one after arrives (not kept: the
        client loses the control mid-write); with ``restart`` it starts again at once, holding its values
        (a control that comes back)."""
        self._stop_after = writes
        self._restart = restart

    async def _bounce(self) -> None:
        await self._stop()
        await self._start()

    def reset(self) -> None:
        """Back to the spec's values, no program running, no write seen, the server up."""
        self._stop_after = None
        self.running = False
        self.writes.clear()
        self.values.clear()
        self.values.update({k: self._grid(v, k) for k, v in self.spec.values.items()})
        if not self.up:
            self.start()

    async def _stop(self) -> None:
        server, self._server = self._server, None
        if server is not None:
            with contextlib.suppress(Exception):
                await server.stop()

    def stop(self) -> None:
        self._call(self._stop())

    def restart(self) -> None:
        """Start again on the same port with the values held (a control that came back)."""
        self.stop()
        self.start()

    @property
    def up(self) -> bool:
        return self._server is not None

    def close(self) -> None:
        self.stop()
        self._loop.call_soon_threadsafe(self._loop.stop)
        self._thread.join(timeout=10)
        self._loop.close()

    # -- another client at the control -------------------------------------------------------
    def edit(self, path: str, value: float) -> None:
        """An operator edits an offset at the control panel."""
        self.values[path] = self._grid(value, path)


@contextlib.contextmanager
def running_control(spec: ControlSpec) -> Iterator[TestControl]:
    control = TestControl(spec)
    control.start()
    try:
        yield control
    finally:
        control.close()


def link_toml(control: TestControl, registers: Mapping[str, Mapping[str, str]], **link: Any) -> str:
    """A link file's text mapping ``{"G54": {"Z": "G54.Z"}}`` (control paths) to the control's nodes.

    ``link`` adds or overrides ``[link]`` keys (None leaves a key out: ``interlock=None``).
    """
    keys: dict[str, Any] = {
        "protocol": "opcua",
        "endpoint": control.endpoint,
        "increment": control.spec.increment,
        "interlock": control.node("Interlock"),
    }
    keys.update(link)
    lines = ["[link]"]
    for key, value in keys.items():
        if value is None:
            continue
        lines.append(f'{key} = "{value}"' if isinstance(value, str) else f"{key} = {value!r}")
    for register, comps in registers.items():
        lines.append(f'[registers."{register}"]')
        lines.extend(f'{comp} = "{control.node(path)}"' for comp, path in comps.items())
    return "\n".join(lines) + "\n"
