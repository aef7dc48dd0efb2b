"""An encrypted session (Basic256Sha256, SignAndEncrypt, certificates) carries the password; an unencrypted or
signed-only one does not, unless the user says ``--insecure``."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from opcua_control import ControlSpec, TestControl, link_toml, make_certificate

from setupfix.cli import main
from setupfix.links import LinkConfigError, load_link, open_link

pytest.importorskip("asyncua")

SECRET = "Encr-9f3-pw"


@pytest.mark.slow  # an OPC UA server starts (seconds)
def test_an_encrypted_session_logs_in_without_insecure(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    server = make_certificate(tmp_path, "server", "urn:setupfix:test-control")
    client = make_certificate(tmp_path, "client", "urn:freeopcua:client")
    control = TestControl(ControlSpec({"G54.Z": -412.53}, increment=0.001, password=SECRET, certificate=server))
    control.start()
    try:
        monkeypatch.setenv("H1_SEC_PW", SECRET)
        link = tmp_path / "link.toml"
        security = f"Basic256Sha256,SignAndEncrypt,{Path(client[0]).name},{Path(client[1]).name}"  # beside the file
        link.write_text(
            link_toml(control, {"G54": {"Z": "G54.Z"}}, user="setter", password_env="H1_SEC_PW", security=security)
        )
        code = main(["machine", "read", "--link", str(link), "--json"])
        out, err = capsys.readouterr()
        assert code == 0, err
        assert json.loads(out)["components"][0]["value"] == -412.53 and SECRET not in out + err
        assert control.users.seen[-1] == ("setter", SECRET)
        plain = tmp_path / "plain.toml"  # the same control without the certificate: the server refuses
        plain.write_text(link_toml(control, {"G54": {"Z": "G54.Z"}}))
        code = main(["machine", "read", "--link", str(plain)])
        _, err = capsys.readouterr()
        assert code == 1 and "[link.security]: " in err and "offers no endpoint with this security" in err
    finally:
        control.close()


@pytest.mark.parametrize("security", [None, "Basic256Sha256,Sign,c.der,k.pem"])
def test_a_password_over_an_unencrypted_session_is_refused(tmp_path: Path, security: str | None) -> None:
    for name in ("c.der", "k.pem"):
        (tmp_path / name).write_bytes(b"")
    text = '[link]\nprotocol = "opcua"\nendpoint = "opc.tcp://127.0.0.1:4840"\nuser = "u"\npassword_env = "PW"\n'
    if security:
        text += f'security = "{security}"\n'
    path = tmp_path / "l.toml"
    path.write_text(text + '[registers."G54"]\nZ = "ns=2;s=z"\n')
    config = load_link(path, environ={"PW": SECRET})
    with pytest.raises(LinkConfigError, match="unencrypted session") as caught:
        open_link(config)
    assert SECRET not in str(caught.value)
    open_link(config, insecure=True).close()  # allowed when asked (nothing connects before a read)
