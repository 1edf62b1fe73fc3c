"""`humanoid serve --tls`: the robot's own certificate authority, a server certificate for every name it is
reached by, and the page, the API and the 3D views over HTTPS."""

from __future__ import annotations

import ipaddress
import socket
from pathlib import Path

import httpx
import pytest
from cryptography import x509
from cryptography.x509 import DNSName, IPAddress
from cryptography.x509.verification import PolicyBuilder, Store, VerificationError

from app.web.tls import ensure_certificate
from harness.server import ServerProcess


def _alternative_names(path: str) -> set[str]:
    cert = x509.load_pem_x509_certificate(Path(path).read_bytes())
    san = cert.extensions.get_extension_for_class(x509.SubjectAlternativeName).value
    return set(san.get_values_for_type(x509.DNSName)) | {str(a) for a in san.get_values_for_type(x509.IPAddress)}


def _verify(ca: bytes, leaf: bytes, name: DNSName | IPAddress) -> None:
    """As a browser that trusts `ca` checks the server's certificate for `name` (name constraints included)."""
    store = Store([x509.load_pem_x509_certificate(ca)])
    PolicyBuilder().store(store).build_server_verifier(name).verify(x509.load_pem_x509_certificate(leaf), [])


def test_the_certificate_covers_every_name_and_is_made_once(tmp_path) -> None:
    files = ensure_certificate(tmp_path, "0.0.0.0")
    names = _alternative_names(files.cert)
    assert {"localhost", "127.0.0.1", "::1", socket.gethostname()} <= names and "0.0.0.0" not in names
    assert (tmp_path / "server-key.pem").stat().st_mode & 0o077 == 0  # the keys are the owner's only
    assert (tmp_path / "ca-key.pem").stat().st_mode & 0o077 == 0
    ca = (tmp_path / "ca.pem").read_bytes()
    for name in (DNSName("localhost"), IPAddress(ipaddress.ip_address("127.0.0.1")), DNSName(socket.gethostname())):
        _verify(ca, Path(files.cert).read_bytes(), name)  # a browser that imported ca.pem trusts it for these
    same = ensure_certificate(tmp_path, "0.0.0.0")
    assert Path(same.cert).read_bytes() == Path(files.cert).read_bytes()  # kept while it covers every name
    renamed = ensure_certificate(tmp_path, "robot-7.local")
    assert "robot-7.local" in _alternative_names(renamed.cert)
    _verify(ca, Path(renamed.cert).read_bytes(), DNSName("robot-7.local"))
    assert (tmp_path / "ca.pem").read_bytes() == ca  # the same authority: browsers need not trust it again
    # the robot's CA vouches for this robot only: not for another site, even asked to
    foreign = ensure_certificate(tmp_path, "bank.example.com")
    assert "bank.example.com" not in _alternative_names(foreign.cert)
    with pytest.raises(VerificationError):
        _verify(ca, Path(foreign.cert).read_bytes(), DNSName("bank.example.com"))


@pytest.mark.slow
def test_serve_tls_serves_the_page_the_api_and_the_3d_views_over_https(tmp_path) -> None:
    with ServerProcess(tmp_path, tls=True, extra_env={"HUMANOID_PERCEPTION": "false"}) as server:
        with server.http() as client:
            assert client.get("/").status_code == 200
            assert client.get("/api/health").json()["status"] == "ok"
            scene = client.get("/api/scene").json()
            view = f"https://localhost:{scene['ports']['light']}/s/{scene['token']}/"
            assert httpx.get(view, verify=str(server.ca), timeout=10).status_code == 200  # the other site, HTTPS too
        with pytest.raises(httpx.HTTPError):  # plain HTTP is not served
            httpx.get(server.url.replace("https", "http") + "/api/health", timeout=5)
