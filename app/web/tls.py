"""HTTPS: the certificate and key the server (and the 3D views' gates) present.

Why HTTPS at all: browsers give a page the microphone only in a secure context, and from another computer that
means HTTPS. `humanoid serve --tls` makes, once, a small certificate authority of this robot (kept in the data
directory) and a server certificate it signs for every name and address the server is reached by; a browser on
another computer trusts the robot once it has imported `ca.pem` (see the docs). A team with certificates of its
own passes `--tls-cert` and `--tls-key` instead.
"""

from __future__ import annotations

import datetime
import ipaddress
import socket
import ssl
from dataclasses import dataclass
from pathlib import Path

import psutil
from cryptography import x509
from cryptography.hazmat.primitives import hashes, serialization
from cryptography.hazmat.primitives.asymmetric import ec
from cryptography.x509.oid import NameOID

CA_YEARS = 10
SERVER_DAYS = 397  # browsers refuse server certificates valid for longer
# What the robot's CA may vouch for, and nothing else (a browser that trusts it trusts only these): this machine's
# names, any `.local` name, and the private, link-local and loopback address ranges (plus the public addresses
# the machine has when the CA is made). A stolen `ca-key.pem` cannot then impersonate another site.
LOCAL_NETWORKS = (
    "10.0.0.0/8",
    "172.16.0.0/12",
    "192.168.0.0/16",
    "100.64.0.0/10",
    "169.254.0.0/16",
    "127.0.0.0/8",
    "::1/128",
    "fc00::/7",
    "fe80::/10",
)


@dataclass(frozen=True)
class TlsFiles:
    """Paths of a PEM certificate (chain) and its key: plain strings, so they cross to the mirrors' process."""

    cert: str
    key: str

    def server_context(self) -> ssl.SSLContext:
        context = ssl.create_default_context(ssl.Purpose.CLIENT_AUTH)
        context.load_cert_chain(self.cert, self.key)
        return context


def server_names(host: str) -> tuple[list[str], list[str]]:
    """(DNS names, IP addresses) this server may be reached by: its names, every address of its interfaces, and
    the address it is told to listen on."""
    names = {"localhost", socket.gethostname(), f"{socket.gethostname()}.local", socket.getfqdn()}
    addresses = {"127.0.0.1", "::1"}
    for interface in psutil.net_if_addrs().values():
        for address in interface:
            if address.family in (socket.AF_INET, socket.AF_INET6):
                addresses.add(address.address.split("%")[0])  # (an IPv6 link-local address's zone is not part)
    try:
        ipaddress.ip_address(host)
        if host not in ("0.0.0.0", "::"):
            addresses.add(host)
    except ValueError:
        names.add(host)
    return sorted(n for n in names if n), sorted(addresses)


def ensure_certificate(directory: Path, host: str) -> TlsFiles:
    """The robot's own certificate for `host` and this machine's names, made (or renewed, when a name or address
    is new or it expires within 30 days) under `directory`, signed by the robot's CA (made once)."""
    directory.mkdir(parents=True, exist_ok=True)
    ca_cert_path, ca_key_path = directory / "ca.pem", directory / "ca-key.pem"
    cert_path, key_path = directory / "server.pem", directory / "server-key.pem"
    names, addresses = server_names(host)
    if not ca_cert_path.exists() or not ca_key_path.exists():
        _write_ca(ca_cert_path, ca_key_path, names, addresses)
    names, addresses, outside = _within_ca(ca_cert_path, names, addresses)
    if outside:
        print(
            f"not in the robot's certificate (its CA may not vouch for them): {', '.join(outside)}; to add "
            f"them, delete {ca_cert_path.parent}/ca*.pem and import the new ca.pem in the browsers again"
        )
    if not _covers(cert_path, names, addresses):
        _write_server(cert_path, key_path, ca_cert_path, ca_key_path, names, addresses)
    return TlsFiles(str(cert_path), str(key_path))


def _now() -> datetime.datetime:
    return datetime.datetime.now(datetime.UTC)


def _private_write(path: Path, data: bytes) -> None:
    path.touch(mode=0o600, exist_ok=True)
    path.chmod(0o600)
    path.write_bytes(data)


def _permitted(names: list[str], addresses: list[str]) -> x509.NameConstraints:
    networks = {ipaddress.ip_network(n) for n in LOCAL_NETWORKS}
    networks |= {ipaddress.ip_network(a) for a in addresses if not any(ipaddress.ip_address(a) in n for n in networks)}
    dns = sorted({*names, "local"})
    return x509.NameConstraints(
        permitted_subtrees=[x509.DNSName(n) for n in dns] + [x509.IPAddress(n) for n in sorted(networks, key=str)],
        excluded_subtrees=None,
    )


def _within_ca(ca_cert_path: Path, names: list[str], addresses: list[str]) -> tuple[list[str], list[str], list[str]]:
    """The names and addresses the CA may vouch for, and the ones it may not."""
    ca = x509.load_pem_x509_certificate(ca_cert_path.read_bytes())
    try:
        constraints = ca.extensions.get_extension_for_class(x509.NameConstraints).value
    except x509.ExtensionNotFound:
        return names, addresses, []
    subtrees = constraints.permitted_subtrees or []
    dns = [t.value for t in subtrees if isinstance(t, x509.DNSName)]
    networks = [t.value for t in subtrees if isinstance(t, x509.IPAddress)]
    ok_names = [n for n in names if any(n == d or n.endswith("." + d) for d in dns)]
    ok_addresses = [a for a in addresses if any(ipaddress.ip_address(a) in net for net in networks)]
    outside = [n for n in names if n not in ok_names] + [a for a in addresses if a not in ok_addresses]
    return ok_names, ok_addresses, outside


def _write_ca(cert_path: Path, key_path: Path, names: list[str], addresses: list[str]) -> None:
    key = ec.generate_private_key(ec.SECP256R1())
    name = x509.Name([x509.NameAttribute(NameOID.COMMON_NAME, f"humanoid mission control CA ({socket.gethostname()})")])
    cert = (
        x509.CertificateBuilder()
        .subject_name(name)
        .issuer_name(name)
        .public_key(key.public_key())
        .serial_number(x509.random_serial_number())
        .not_valid_before(_now() - datetime.timedelta(days=1))
        .not_valid_after(_now() + datetime.timedelta(days=365 * CA_YEARS))
        .add_extension(x509.BasicConstraints(ca=True, path_length=0), critical=True)
        .add_extension(
            x509.KeyUsage(
                digital_signature=False,
                content_commitment=False,
                key_encipherment=False,
                data_encipherment=False,
                key_agreement=False,
                key_cert_sign=True,
                crl_sign=True,
                encipher_only=False,
                decipher_only=False,
            ),
            critical=True,
        )
        .add_extension(x509.SubjectKeyIdentifier.from_public_key(key.public_key()), critical=False)
        .add_extension(_permitted(names, addresses), critical=True)
        .sign(key, hashes.SHA256())
    )
    _private_write(
        key_path,
        key.private_bytes(serialization.Encoding.PEM, serialization.PrivateFormat.PKCS8, serialization.NoEncryption()),
    )
    cert_path.write_bytes(cert.public_bytes(serialization.Encoding.PEM))


def _covers(cert_path: Path, names: list[str], addresses: list[str]) -> bool:
    if not cert_path.exists():
        return False
    try:
        cert = x509.load_pem_x509_certificate(cert_path.read_bytes())
        san = cert.extensions.get_extension_for_class(x509.SubjectAlternativeName).value
    except (ValueError, x509.ExtensionNotFound):
        return False
    have_names = set(san.get_values_for_type(x509.DNSName))
    have_addresses = {str(a) for a in san.get_values_for_type(x509.IPAddress)}
    fresh = cert.not_valid_after_utc - _now() > datetime.timedelta(days=30)
    return fresh and set(names) <= have_names and {str(ipaddress.ip_address(a)) for a in addresses} <= have_addresses


def _write_server(
    cert_path: Path, key_path: Path, ca_cert_path: Path, ca_key_path: Path, names: list[str], addresses: list[str]
) -> None:
    ca_cert = x509.load_pem_x509_certificate(ca_cert_path.read_bytes())
    ca_key = serialization.load_pem_private_key(ca_key_path.read_bytes(), password=None)
    key = ec.generate_private_key(ec.SECP256R1())
    alternative = [x509.DNSName(n) for n in names] + [x509.IPAddress(ipaddress.ip_address(a)) for a in addresses]
    cert = (
        x509.CertificateBuilder()
        .subject_name(x509.Name([x509.NameAttribute(NameOID.COMMON_NAME, socket.gethostname())]))
        .issuer_name(ca_cert.subject)
        .public_key(key.public_key())
        .serial_number(x509.random_serial_number())
        .not_valid_before(_now() - datetime.timedelta(days=1))
        .not_valid_after(_now() + datetime.timedelta(days=SERVER_DAYS))
        .add_extension(x509.SubjectAlternativeName(alternative), critical=False)
        .add_extension(x509.BasicConstraints(ca=False, path_length=None), critical=True)
        .add_extension(x509.ExtendedKeyUsage([x509.oid.ExtendedKeyUsageOID.SERVER_AUTH]), critical=False)
        .add_extension(
            x509.AuthorityKeyIdentifier.from_issuer_public_key(ca_cert.public_key()),  # type: ignore[arg-type]
            critical=False,
        )
        .sign(ca_key, hashes.SHA256())  # type: ignore[arg-type]
    )
    _private_write(
        key_path,
        key.private_bytes(serialization.Encoding.PEM, serialization.PrivateFormat.PKCS8, serialization.NoEncryption()),
    )
    cert_path.write_bytes(cert.public_bytes(serialization.Encoding.PEM))
