"""The OPC UA link (``asyncua``): a control's offset table through a per-machine node map.

No OPC UA companion specification holds offset tables (OPC 40502 exposes only the active
offset function), so the link file maps every register component to a node
(:mod:`setupfix.links.config`).  The link runs its own event loop in one background thread,
so it works the same from a plain script, a batch worker or a thread of the TUI (which has its
own loop); :meth:`OpcUaLink.close` disconnects, stops the loop and joins the thread (no loop
is left behind).  It connects on first use, and once more after a lost connection (the
roll-back of a write needs a fresh session).

A password never travels over an unencrypted session unless the link was opened with
``insecure``: the security string must name ``SignAndEncrypt``.
"""

from __future__ import annotations

import asyncio
import concurrent.futures
import contextlib
import logging
import threading
from collections.abc import Coroutine, Iterable, Mapping
from types import TracebackType
from typing import TYPE_CHECKING, Any, TypeVar

from setupfix.links.base import Component
from setupfix.links.config import LinkConfig
from setupfix.links.errors import LinkConfigError, LinkDenied, LinkError, LinkLost, LinkUnreachable

if TYPE_CHECKING:
    from asyncua.client.client import Client
    from asyncua.common.node import Node

__all__ = ["OpcUaLink", "open_opcua"]

T = TypeVar("T")

#: asyncua logs its own warnings (and a stack for every failed connection); the link reports
#: errors as one line itself, so only the library's errors pass.
_QUIET = ("asyncua",)


def open_opcua(config: LinkConfig) -> OpcUaLink:
    """The :data:`setupfix.links.LINKS` opener of ``protocol = "opcua"``.

    Raises
    ------
    LinkError
        ``asyncua`` is not installed (``pip install 'setupfix[machine]'``).
    """
    try:
        import asyncua  # noqa: F401 - only to know it is there
    except ImportError:
        raise LinkError(
            f"{config.name}: the OPC UA link needs the asyncua package", hint="pip install 'setupfix[machine]'"
        ) from None
    return OpcUaLink(config)


class OpcUaLink:
    """A link to one OPC UA server (see the module docstring).

    Raises
    ------
    LinkConfigError
        At open: a password over an unencrypted session without ``config.insecure``.
    """

    def __init__(self, config: LinkConfig) -> None:
        if config.password is not None and not (config.security and config.security.encrypted) and not config.insecure:
            raise LinkConfigError(
                "refused: the password would travel over an unencrypted session",
                location=config.where("link.security"),
                hint="security = 'Basic256Sha256,SignAndEncrypt,cert.pem,key.pem', or --insecure on a trusted network",
            )
        for name in _QUIET:
            logging.getLogger(name).setLevel(logging.ERROR)
        self.config = config
        self.name = config.name
        self.unit = config.unit
        self.increment = config.increment
        self.machine = config.machine
        self._nodes = config.node_map
        self._client: Client | None = None
        self._types: dict[str, Any] = {}
        self._loop = asyncio.new_event_loop()
        self._thread = threading.Thread(target=self._loop.run_forever, name="opcua-link", daemon=True)
        self._thread.start()
        self._closed = False

    # -- the event loop ------------------------------------------------------------------------
    def _run(self, coro: Coroutine[Any, Any, T]) -> T:
        if self._closed:
            coro.close()
            raise LinkError(f"{self.name}: the link is closed")
        future = asyncio.run_coroutine_threadsafe(coro, self._loop)
        try:
            return future.result(timeout=4 * self.config.timeout + 5)
        except concurrent.futures.TimeoutError:
            future.cancel()
            raise LinkLost(f"{self.name}: no answer within {self.config.timeout:g} s") from None

    async def _connect(self) -> Client:
        from asyncua.client.client import Client
        from asyncua.ua.uaerrors import UaStatusCodeError

        if self._client is not None:
            return self._client
        client = Client(self.config.endpoint or "", timeout=self.config.timeout)
        if self.config.user is not None:
            client.set_user(self.config.user)
        if self.config.password is not None:
            client.set_password(self.config.password)
        try:
            if self.config.security is not None:
                await client.set_security_string(self.config.security.asyncua_string())
            await asyncio.wait_for(client.connect(), timeout=self.config.timeout * 2)
        except UaStatusCodeError as exc:
            code = type(exc).__name__
            with contextlib.suppress(Exception):
                await asyncio.wait_for(client.disconnect(), timeout=1.0)
            if "Identity" in code or "UserAccess" in code or "Security" in code or "Certificate" in code:
                raise LinkDenied(
                    f"{self.name}: the control refused the session ({code})",
                    hint="check [link] user, the password variable and the security string",
                ) from None
            raise LinkUnreachable(f"{self.name}: cannot reach the control: {code}") from None
        except Exception as exc:  # noqa: BLE001 - every other failure to connect is "unreachable"
            if "No matching endpoints" in str(exc):
                raise LinkConfigError(
                    f"{self.name}: the control offers no endpoint with this security ({_reason(exc)})",
                    location=self.config.where("link.security"),
                ) from None
            raise LinkUnreachable(f"{self.name}: cannot reach the control: {_reason(exc)}") from None
        self._client = client
        return client

    async def _drop(self) -> None:
        """Forget a broken session (the next request reconnects)."""
        client, self._client = self._client, None
        if client is not None:
            with contextlib.suppress(Exception):  # the session is already gone
                await asyncio.wait_for(client.disconnect(), timeout=1.0)

    async def _node(self, client: Client, text: str) -> Node:
        from asyncua import ua

        if text.startswith("nsu="):
            uri, _, rest = text[4:].partition(";")
            index = await client.get_namespace_index(uri)
            text = f"ns={index};{rest}"
        return client.get_node(ua.NodeId.from_string(text))

    def _check(self, components: Iterable[Component]) -> list[Component]:
        wanted = list(dict.fromkeys(components))
        missing = [c for c in wanted if c not in self._nodes]
        if missing:
            raise LinkConfigError(
                f"not mapped to a node: {', '.join(str(c) for c in missing)} (nothing read or written)",
                location=self.config.where("registers"),
            )
        return wanted

    # -- the Link protocol ---------------------------------------------------------------------
    def components(self) -> tuple[Component, ...]:
        return tuple(self._nodes)

    def read(self, components: Iterable[Component]) -> dict[Component, float]:
        wanted = self._check(components)
        return self._run(self._read(wanted))

    async def _read(self, wanted: list[Component]) -> dict[Component, float]:
        client = await self._connect()
        out: dict[Component, float] = {}
        for comp in wanted:
            value, vtype = await self._read_value(client, self._nodes[comp], str(comp))
            if isinstance(value, bool) or not isinstance(value, int | float):
                raise LinkError(f"{self.name}: {comp} (node {self._nodes[comp]}) holds {value!r}, not a number")
            self._types[self._nodes[comp]] = vtype
            out[comp] = float(value)
        return out

    async def _read_value(self, client: Client, node_id: str, label: str) -> tuple[Any, Any]:
        from asyncua.ua.uaerrors import UaStatusCodeError

        try:
            node = await self._node(client, node_id)
            dv = await node.read_data_value()
        except UaStatusCodeError as exc:
            raise _status_error(self.name, label, node_id, exc) from None
        except LinkError:
            raise
        except Exception as exc:  # noqa: BLE001 - the session broke mid-request
            await self._drop()
            raise LinkLost(f"{self.name}: connection lost reading {label}: {_reason(exc)}") from None
        if dv.StatusCode is not None and not dv.StatusCode.is_good():
            raise LinkError(f"{self.name}: {label} (node {node_id}) answered {dv.StatusCode.name}")
        variant = dv.Value
        return (variant.Value, variant.VariantType) if variant is not None else (None, None)

    def write(self, values: Mapping[Component, float]) -> None:
        wanted = self._check(values)
        self._run(self._write({c: float(values[c]) for c in wanted}))

    async def _write(self, values: dict[Component, float]) -> None:
        from asyncua import ua
        from asyncua.ua.uaerrors import UaStatusCodeError

        client = await self._connect()
        for comp, value in values.items():
            node_id = self._nodes[comp]
            try:
                node = await self._node(client, node_id)
                vtype = self._types.get(node_id)
                if vtype is None:
                    vtype = await node.read_data_type_as_variant_type()
                    self._types[node_id] = vtype
                await node.write_value(ua.DataValue(ua.Variant(_typed(value, vtype), vtype)))
            except UaStatusCodeError as exc:
                raise _status_error(self.name, str(comp), node_id, exc) from None
            except LinkError:
                raise
            except Exception as exc:  # noqa: BLE001 - the session broke mid-write
                await self._drop()
                raise LinkLost(f"{self.name}: connection lost writing {comp}: {_reason(exc)}") from None

    def interlocked(self) -> bool:
        if self.config.interlock is None:
            return False
        return self._run(self._interlocked(self.config.interlock))

    async def _interlocked(self, node_id: str) -> bool:
        client = await self._connect()
        value, _ = await self._read_value(client, node_id, "the interlock")
        if not isinstance(value, bool):
            raise LinkError(
                f"{self.name}: the interlock node {node_id} holds {value!r}, not a boolean",
                hint="[link] interlock names a boolean node: true = offset writes refused now",
            )
        return value

    def close(self) -> None:
        if self._closed:
            return
        try:
            self._run(self._drop())
        finally:
            self._closed = True
            self._loop.call_soon_threadsafe(self._loop.stop)
            self._thread.join(timeout=5)
            if not self._thread.is_alive():
                self._loop.close()

    def __enter__(self) -> OpcUaLink:
        return self

    def __exit__(self, kind: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None) -> None:
        self.close()

    def __repr__(self) -> str:
        return f"OpcUaLink({self.name!r})"


def _typed(value: float, vtype: Any) -> float | int:
    """The value as the node's variant type holds it (an integer node gets an int)."""
    from asyncua import ua

    integers = {ua.VariantType.Int16, ua.VariantType.Int32, ua.VariantType.Int64, ua.VariantType.UInt32}
    return round(value) if vtype in integers else float(value)


def _status_error(name: str, label: str, node_id: str, exc: Exception) -> LinkError:
    """A bad status of the server as a link error naming the component and node."""
    code = getattr(exc, "code_as_name", lambda: type(exc).__name__)()
    if code in ("BadUserAccessDenied", "BadNotWritable", "BadNotReadable"):
        return LinkDenied(f"{name}: {label} (node {node_id}): the control answered {code}")
    if code == "BadNodeIdUnknown":
        return LinkConfigError(f"{name}: {label}: the control has no node {node_id}")
    return LinkError(f"{name}: {label} (node {node_id}): the control answered {code}")


def _reason(exc: BaseException) -> str:
    """One line: what went wrong, without a stack (and without any credential: the endpoint holds none)."""
    text = str(exc).strip().splitlines()[0] if str(exc).strip() else ""
    return f"{type(exc).__name__}: {text}" if text else type(exc).__name__
