"""A small lab CA and one certificate + password per bus node (``gaitcap bus-keys``).

``make_bus_keys(bus, out)`` writes into ``out`` (created 0700):

- ``ca.pem`` (the lab CA certificate, every host) and ``ca.key`` (its private key: keep it on the
  administrator's machine, it is only needed to add nodes later);
- ``<node>.pem`` / ``<node>.key`` for every node and client of the bus file (common name = node name;
  subject alternative names = the host of the node's endpoint, ``localhost`` and ``127.0.0.1``), ECDSA
  P-256, valid ``days`` days; a host gets only its own nodes' keys;
- ``passwords.txt``: ``node:password`` lines (Zenoh's user/password dictionary), random 32-byte tokens.

Private files are written 0600. Existing files are kept (re-running adds the missing nodes with the same CA).
"""

from __future__ import annotations

import datetime
import ipaddress
import os
import secrets
from pathlib import Path

from cryptography import x509
from cryptography.hazmat.primitives import hashes, serialization
from cryptography.hazmat.primitives.asymmetric import ec
from cryptography.x509.oid import ExtendedKeyUsageOID, NameOID


def _name(cn: str) -> x509.Name:
    return x509.Name([x509.NameAttribute(NameOID.COMMON_NAME, cn)])


def _write_private(path: Path, data: bytes) -> None:
    fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
    with os.fdopen(fd, "wb") as f:
        f.write(data)


def _key_pem(key) -> bytes:
    return key.private_bytes(serialization.Encoding.PEM, serialization.PrivateFormat.PKCS8,
                             serialization.NoEncryption())


def lab_ca(out: Path, days: int = 3650):
    """The lab CA in ``out`` (``ca.pem``, ``ca.key`` 0600), created when missing: (certificate, key)."""
    pem, key_file = out / "ca.pem", out / "ca.key"
    if pem.exists() and key_file.exists():
        return (x509.load_pem_x509_certificate(pem.read_bytes()),
                serialization.load_pem_private_key(key_file.read_bytes(), password=None))
    key = ec.generate_private_key(ec.SECP256R1())
    now = datetime.datetime.now(datetime.UTC)
    cert = (x509.CertificateBuilder().subject_name(_name("gaitcap lab CA")).issuer_name(_name("gaitcap lab CA"))
            .public_key(key.public_key()).serial_number(x509.random_serial_number())
            .not_valid_before(now - datetime.timedelta(minutes=5)).not_valid_after(now + datetime.timedelta(days=days))
            .add_extension(x509.BasicConstraints(ca=True, path_length=0), critical=True)
            .add_extension(x509.KeyUsage(digital_signature=True, key_cert_sign=True, crl_sign=True,
                                         content_commitment=False, key_encipherment=False, data_encipherment=False,
                                         key_agreement=False, encipher_only=False, decipher_only=False), critical=True)
            .add_extension(x509.SubjectKeyIdentifier.from_public_key(key.public_key()), critical=False)
            .sign(key, hashes.SHA256()))
    _write_private(key_file, _key_pem(key))
    pem.write_bytes(cert.public_bytes(serialization.Encoding.PEM))
    return cert, key


def _alt_names(host: str | None) -> list[x509.GeneralName]:
    names: list[x509.GeneralName] = [x509.DNSName("localhost"), x509.IPAddress(ipaddress.ip_address("127.0.0.1"))]
    if host and host not in ("localhost", "127.0.0.1"):
        try:
            names.append(x509.IPAddress(ipaddress.ip_address(host.strip("[]"))))
        except ValueError:
            names.append(x509.DNSName(host))
    return names


def node_certificate(ca_cert, ca_key, node: str, host: str | None, *, days: int):
    """(certificate, private key) of ``node`` signed by the CA, for server and client use (mTLS)."""
    key = ec.generate_private_key(ec.SECP256R1())
    now = datetime.datetime.now(datetime.UTC)
    cert = (x509.CertificateBuilder().subject_name(_name(node)).issuer_name(ca_cert.subject)
            .public_key(key.public_key()).serial_number(x509.random_serial_number())
            .not_valid_before(now - datetime.timedelta(minutes=5)).not_valid_after(now + datetime.timedelta(days=days))
            .add_extension(x509.SubjectAlternativeName(_alt_names(host)), critical=False)
            .add_extension(x509.BasicConstraints(ca=False, path_length=None), critical=True)
            .add_extension(x509.ExtendedKeyUsage([ExtendedKeyUsageOID.SERVER_AUTH, ExtendedKeyUsageOID.CLIENT_AUTH]),
                           critical=False)
            .add_extension(x509.AuthorityKeyIdentifier.from_issuer_public_key(ca_key.public_key()), critical=False)
            .sign(ca_key, hashes.SHA256()))
    return cert, key


def web_certificate(host: str, out: str | os.PathLike, *, days: int = 825) -> tuple[Path, Path]:
    """A certificate for the web service on ``host`` signed by the lab CA in ``out`` (kept when present):
    (``web.pem``, ``web.key``). Install ``out/ca.pem`` in the clinic browsers to trust it."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    out.chmod(0o700)
    pem, key_file = out / "web.pem", out / "web.key"
    if not (pem.exists() and key_file.exists()):
        ca_cert, ca_key = lab_ca(out)
        cert, key = node_certificate(ca_cert, ca_key, host, host, days=days)
        _write_private(key_file, _key_pem(key))
        pem.write_bytes(cert.public_bytes(serialization.Encoding.PEM))
    return pem, key_file


def _host_of(endpoint: str | None) -> str | None:
    if not endpoint:
        return None
    return endpoint.split("/", 1)[1].rsplit(":", 1)[0]


def make_bus_keys(identities: dict[str, str | None], out: str | os.PathLike, *, days: int = 825) -> list[str]:
    """CA, certificates and passwords for ``identities`` (name -> endpoint or None) in ``out``.

    Returns the names whose files were created now (existing ones are kept)."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    out.chmod(0o700)
    ca_cert, ca_key = lab_ca(out, days=max(days, 3650))
    made = []
    for node, endpoint in identities.items():
        pem, key_file = out / f"{node}.pem", out / f"{node}.key"
        if pem.exists() and key_file.exists():
            continue
        cert, key = node_certificate(ca_cert, ca_key, node, _host_of(endpoint), days=days)
        _write_private(key_file, _key_pem(key))
        pem.write_bytes(cert.public_bytes(serialization.Encoding.PEM))
        made.append(node)
    _add_passwords(out / "passwords.txt", list(identities))
    return made


def _add_passwords(path: Path, names: list[str]) -> None:
    existing = {}
    if path.exists():
        existing = dict(line.split(":", 1) for line in path.read_text().splitlines() if ":" in line)
    lines = [f"{n}:{existing.get(n) or secrets.token_urlsafe(32)}" for n in dict.fromkeys([*existing, *names])]
    tmp = path.with_name(path.name + ".tmp")
    tmp.unlink(missing_ok=True)
    _write_private(tmp, ("\n".join(lines) + "\n").encode())
    tmp.replace(path)
