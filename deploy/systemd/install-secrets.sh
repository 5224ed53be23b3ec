#!/usr/bin/env bash
# Make this rig's secrets once, on the processing host, as root: the bus keys (lab CA, one certificate and
# password per node), the web service's HTTPS certificate (signed by the same lab CA) and the first admin
# account. Nothing secret is shipped in the repository. Then copy to each acquisition host: ca.pem,
# passwords.txt and its own camera-K.pem/.key (into the same keys folder, owner gaitcap, mode 0600).
set -euo pipefail
GAITCAP=${GAITCAP:-/opt/gaitcap/.venv/bin/gaitcap}
PY=${PY:-/opt/gaitcap/.venv/bin/python}
ETC=${ETC:-/etc/gaitcap}
HOST=${1:?usage: install-secrets.sh WEB_HOST_NAME_OR_IP [ADMIN_USER]}
ADMIN=${2:-admin}
umask 077
"$GAITCAP" bus-keys --bus "$ETC/bus.json5" --client operator
"$PY" -c 'import sys; from gaitcap.services.bus.certs import web_certificate; print(*web_certificate(sys.argv[1], sys.argv[2]))' \
    "$HOST" "$ETC/tls"
chown -R gaitcap:gaitcap "$ETC/tls" "$(dirname "$ETC/bus-keys/x")"
echo "Clinic browsers must trust $ETC/tls/ca.pem (the lab CA). Keep $ETC/bus-keys/ca.key off the rig."
sudo -u gaitcap GAITCAP_DATA_DIR="${GAITCAP_DATA_DIR:-/srv/gaitcap}" "$GAITCAP" user add "$ADMIN" --role admin
