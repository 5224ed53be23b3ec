"""Bus security: mutual TLS, user/password authentication and Zenoh access control, per node role.

A secured bus file names a keys folder made by ``gaitcap bus-keys`` (:mod:`gaitcap.services.bus.certs`)::

    security: {
      keys_dir: "/etc/gaitcap/bus-keys",   // ca.pem, <node>.pem, <node>.key, passwords.txt
      clients: ["operator"],               // identities that listen nowhere (CLI tools); role "client"
      cameras: {"camera-0": ["cam01", "cam02"]},  // optional: the cameras each camera node may publish
    }

Every node then: listens and connects on ``tls/`` endpoints only, presents its certificate (common name =
node name) and checks the peer's against the lab CA (mTLS); authenticates with its user name (= node name)
and password; and filters what it receives by the sender's role (Zenoh ``access_control``, default deny):

=========  =================================================================================
role       may send (put / query / reply) to the other nodes
=========  =================================================================================
camera     put ``camera/<its cameras>/image|status``
detector   put ``keypoints/*``, ``detector/status/*`` and ``board/views/*``
recorder   put ``recorder/events``; reply on ``recorder/**``
worker     query ``recorder/recording/*`` (a recording, fetched without the shared store)
api        put ``camera/scene`` and ``board/watch``; query ``recorder/**``
replay     put ``camera/*/image|status`` and ``keypoints/*``
client     nothing but declarations and liveliness (reads what the others let it subscribe to)
=========  =================================================================================

Every role may declare subscribers, queryables and liveliness tokens and query liveliness. The role of
a node is its name (``camera-K`` -> camera, ``worker-K`` -> worker, ``detector-K`` -> detector); unknown names are clients.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from gaitcap.services.bus.keys import check_name

#: Messages every authenticated node may exchange (declarations and liveliness).
_DECLARATIONS = ("declare_subscriber", "declare_queryable", "liveliness_token", "declare_liveliness_subscriber",
                 "liveliness_query")

#: role -> [(messages, key expressions under the prefix)] it may SEND (checked on ingress by the others).
ROLE_SENDS: dict[str, tuple[tuple[tuple[str, ...], tuple[str, ...]], ...]] = {
    "camera": ((("put",), ("camera/*/image", "camera/*/status")),),
    "detector": ((("put",), ("keypoints/*", "detector/status/*", "board/views/*")),),
    "recorder": ((("put",), ("recorder/events",)), (("reply",), ("recorder/**",))),
    "worker": ((("query",), ("recorder/recording/*",)),),
    "api": ((("put",), ("camera/scene", "board/watch")), (("query",), ("recorder/**",))),
    "replay": ((("put",), ("camera/*/image", "camera/*/status", "keypoints/*")),),
    "client": (),
}
_ROLE_OF_NAME = (("camera", re.compile(r"^camera(-.*)?$")), ("worker", re.compile(r"^worker(-.*)?$")),
                 ("detector", re.compile(r"^detector(-.*)?$")))


def role_of(node: str) -> str:
    """The role of a node name (``camera-0`` -> camera, ``recorder`` -> recorder, others -> client)."""
    for role, pattern in _ROLE_OF_NAME:
        if pattern.match(node):
            return role
    return node if node in ROLE_SENDS else "client"


def _matches(pattern: list[str], key: list[str]) -> bool:
    if not pattern:
        return not key
    if pattern[0] == "**":
        return any(_matches(pattern[1:], key[i:]) for i in range(len(key) + 1))
    return bool(key) and pattern[0] in ("*", key[0]) and _matches(pattern[1:], key[1:])


def may_send(node: str, message: str, key: str) -> bool:
    """Whether the others let ``node`` send ``message`` (``put``, ``query``, ``reply``) on ``key`` (under the
    prefix, e.g. ``recorder/recording/T1``) on a secured bus: its role's line of :data:`ROLE_SENDS`."""
    return any(message in messages and any(_matches(k.split("/"), key.split("/")) for k in keys)
               for messages, keys in ROLE_SENDS[role_of(node)])


@dataclass(frozen=True)
class BusSecurity:
    """The ``security`` section of a bus file (see the module docstring).

    Attributes:
        keys_dir: folder with ``ca.pem``, ``<node>.pem``, ``<node>.key`` and ``passwords.txt``.
        clients: identities that listen nowhere (CLI tools, scripts); role ``client``.
        cameras: camera node -> the camera names it may publish (default: any camera key).
    """

    keys_dir: Path
    clients: tuple[str, ...] = ()
    cameras: dict[str, tuple[str, ...]] = field(default_factory=dict)

    def __post_init__(self) -> None:
        object.__setattr__(self, "keys_dir", Path(self.keys_dir))
        object.__setattr__(self, "clients", tuple(check_name(c, what="security.clients") for c in self.clients))
        cams = {check_name(n, what="security.cameras"): tuple(check_name(c, what=f"security.cameras.{n}") for c in v)
                for n, v in dict(self.cameras).items()}
        object.__setattr__(self, "cameras", cams)

    @classmethod
    def from_dict(cls, data: Any, *, base: Path) -> BusSecurity:
        if not isinstance(data, dict) or "keys_dir" not in data:
            raise ValueError("security: expected an object with keys_dir (made by 'gaitcap bus-keys')")
        unknown = sorted(set(data) - {"keys_dir", "clients", "cameras"})
        if unknown:
            raise ValueError(f"security: unknown fields {unknown}")
        keys_dir = Path(data["keys_dir"]).expanduser()
        return cls(keys_dir if keys_dir.is_absolute() else base / keys_dir, tuple(data.get("clients", ())),
                   dict(data.get("cameras", {})))

    def to_dict(self) -> dict[str, Any]:
        return {"keys_dir": str(self.keys_dir), "clients": list(self.clients),
                "cameras": {k: list(v) for k, v in self.cameras.items()}}

    def cert(self, node: str) -> tuple[Path, Path]:
        """(certificate, private key) of ``node``; ValueError naming the missing file."""
        pem, key = self.keys_dir / f"{node}.pem", self.keys_dir / f"{node}.key"
        for f in (self.keys_dir / "ca.pem", pem, key, self.passwords_file):
            if not f.is_file():
                raise ValueError(f"bus security: {f} is missing (run 'gaitcap bus-keys' and copy node {node}'s "
                                 "files to this host)")
        return pem, key

    @property
    def passwords_file(self) -> Path:
        return self.keys_dir / "passwords.txt"

    def password(self, node: str) -> str:
        for line in self.passwords_file.read_text().splitlines():
            user, sep, password = line.partition(":")
            if sep and user == node:
                return password
        raise ValueError(f"bus security: no password for node {node} in {self.passwords_file}")


def access_control(prefix: str, identities: list[str], cameras: dict[str, tuple[str, ...]]) -> dict[str, Any]:
    """The Zenoh ``access_control`` section: default deny; each identity may send what its role allows."""
    rules = [
        {"id": "declarations", "permission": "allow", "flows": ["ingress", "egress"],
         "messages": list(_DECLARATIONS), "key_exprs": [f"{prefix}/**"]},
        {"id": "liveliness-replies", "permission": "allow", "flows": ["ingress"], "messages": ["reply"],
         "key_exprs": [f"{prefix}/alive/**"]},
        {"id": "send", "permission": "allow", "flows": ["egress"],
         "messages": ["put", "delete", "query", "reply"], "key_exprs": [f"{prefix}/**"]},
    ]
    # The certificate's common name identifies the sender on both ends of a link (Zenoh's user name is
    # only known to the accepting end); user/password is checked by the accepting end on every link.
    subjects = [{"id": name, "cert_common_names": [name]} for name in identities]
    policies = [{"rules": ["declarations", "liveliness-replies", "send"], "subjects": list(identities)}]
    for name in identities:
        rule_ids = []
        for i, (messages, keys) in enumerate(ROLE_SENDS[role_of(name)]):
            own = cameras.get(name)
            if own is not None and role_of(name) == "camera":
                keys = tuple(f"camera/{c}/{k.rsplit('/', 1)[1]}" for c in own for k in keys)
            rules.append({"id": f"{name}-{i}", "permission": "allow", "flows": ["ingress"], "messages": list(messages),
                          "key_exprs": [f"{prefix}/{k}" for k in keys]})
            rule_ids.append(f"{name}-{i}")
        if rule_ids:
            policies.append({"rules": rule_ids, "subjects": [name]})
    return {"enabled": True, "default_permission": "deny", "rules": rules, "subjects": subjects,
            "policies": policies}


def zenoh_security(security: BusSecurity, node: str, *, prefix: str, identities: list[str]) -> dict[str, Any]:
    """``{config path: value}`` to insert into a node's ``zenoh.Config``."""
    if node not in identities:
        raise ValueError(f"bus security: {node!r} is not a node or client of the bus file {sorted(identities)}")
    pem, key = security.cert(node)
    tls = {"root_ca_certificate": str(security.keys_dir / "ca.pem"), "enable_mtls": True,
           "listen_certificate": str(pem), "listen_private_key": str(key),
           "connect_certificate": str(pem), "connect_private_key": str(key), "verify_name_on_connect": True}
    usrpwd = {"user": node, "password": security.password(node), "dictionary_file": str(security.passwords_file)}
    return {"transport/link/tls": tls, "transport/auth/usrpwd": usrpwd,
            "access_control": access_control(prefix, identities, security.cameras)}
