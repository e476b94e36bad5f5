#!/usr/bin/env bash
# Makes the secrets a kgd deployment needs into DIR (default deploy/secrets, which git ignores):
#   ca.pem, ca.key            a certificate authority of your own (keep ca.key offline)
#   tls.crt, tls.key          the server's certificate for the names given (default kgd-server and server, with localhost)
#   tokens.txt                tokens: admin, worker, and one user per name in $KGD_USERS (default alice)
# Usage: deploy/make-secrets.sh [DIR] [DNS names...]
set -euo pipefail
dir=${1:-$(dirname "$0")/secrets}
shift || true
if [ $# -gt 0 ]; then names=("$@"); else names=(kgd-server server); fi
mkdir -p "$dir"
chmod 0700 "$dir"
cd "$dir"
san="DNS:localhost,IP:127.0.0.1"
for n in "${names[@]}"; do san="$san,DNS:$n,DNS:$n.kgd.svc.cluster.local"; done
[ -f ca.pem ] || openssl req -x509 -newkey rsa:2048 -nodes -keyout ca.key -out ca.pem -days 825 -subj /CN=kgd-ca 2>/dev/null
openssl req -newkey rsa:2048 -nodes -keyout tls.key -out tls.csr -subj "/CN=${names[0]}" 2>/dev/null
printf 'subjectAltName=%s\n' "$san" > san.ext
openssl x509 -req -in tls.csr -CA ca.pem -CAkey ca.key -CAcreateserial -out tls.crt -days 825 -extfile san.ext 2>/dev/null
rm -f tls.csr san.ext
token() { openssl rand -hex 16; }
if [ ! -f tokens.txt ]; then
  {
    echo "# TOKEN USER ROLE"
    echo "$(token) admin admin"
    echo "$(token) workers worker"
    for u in ${KGD_USERS:-alice}; do echo "$(token) $u user"; done
  } > tokens.txt
fi
awk '$3 == "worker" {print $1}' tokens.txt > worker-token
chmod 0600 ./*
echo "secrets in $dir: ca.pem (give to clients as --tls-ca), tls.crt, tls.key, tokens.txt, worker-token"
