#!/usr/bin/env bash
# Builds kgd's images from deploy/docker/Dockerfile with buildah, without a daemon or a registry:
#   1. the base images debian:12 and debian:12-slim, when absent, from `debootstrap --variant=minbase
#      bookworm` against the Debian mirror apt uses here, or $KGD_DEBIAN_MIRROR (its sources go into the image too, so the
#      build stage installs the same package versions as this machine);
#   2. the targets server, worker and cli, tagged kgd-server, kgd-worker and kgd-cli.
# Needs root and buildah and debootstrap (`scripts/setup.sh --images`). Storage driver vfs, chroot
# isolation, host network for the build stage's apt-get and npm ci; builds never pull (--pull=never).
# The images are in Docker's format, which keeps the HEALTHCHECK (OCI's has none).
# Prints each image's size and build time, and writes them to $KGD_IMAGES_REPORT (default
# build/images.txt).
# Usage: deploy/images.sh [--rebuild-base]
set -euo pipefail
cd "$(dirname "$0")/.."
export STORAGE_DRIVER=vfs BUILDAH_ISOLATION=chroot
report=${KGD_IMAGES_REPORT:-build/images.txt}
mkdir -p "$(dirname "$report")"

exists() { buildah inspect --type image "$1" > /dev/null 2>&1; }

# The Debian mirror: $KGD_DEBIAN_MIRROR, else the one apt uses on this machine (first URIs: of a deb822
# source, else the first bookworm deb line); none found is an error that says what to set.
mirror() {
  local m="${KGD_DEBIAN_MIRROR:-}"
  if [ -z "$m" ] && [ -f /etc/apt/sources.list.d/debian.sources ]; then
    m=$(awk '/^URIs:/ {print $2; exit}' /etc/apt/sources.list.d/debian.sources)
  fi
  if [ -z "$m" ] && [ -f /etc/apt/sources.list ]; then
    m=$(awk '$1 == "deb" && $0 ~ /bookworm/ {for (i = 2; i <= NF; i++) if ($i ~ /^https?:/) {print $i; exit}}' /etc/apt/sources.list)
  fi
  if [ -z "$m" ]; then
    echo "images: no Debian mirror: KGD_DEBIAN_MIRROR is unset and neither /etc/apt/sources.list.d/debian.sources nor /etc/apt/sources.list names a bookworm one; set KGD_DEBIAN_MIRROR (e.g. KGD_DEBIAN_MIRROR=http://deb.debian.org/debian)" >&2
    return 1
  fi
  echo "$m"
}

make_base() {
  local t0=$SECONDS root ctr
  root=$(mktemp -d /var/tmp/kgd-rootfs.XXXXXX)
  trap 'rm -rf "$root"' RETURN
  local from
  from=$(mirror) || exit 1
  echo "images: debootstrap --variant=minbase bookworm from $from"
  debootstrap --variant=minbase bookworm "$root" "$from" > "$root.log" 2>&1 || { tail -20 "$root.log"; exit 1; }
  rm -f "$root.log"
  # The same sources as this machine (e.g. bookworm-updates and bookworm-security): the build stage
  # then installs the versions this machine runs (glibc and OpenBLAS shape the results bit for bit).
  if [ -f /etc/apt/sources.list.d/debian.sources ]; then
    cp /etc/apt/sources.list.d/debian.sources "$root/etc/apt/sources.list.d/debian.sources"
    rm -f "$root/etc/apt/sources.list"
  elif grep -qs '^deb .*bookworm' /etc/apt/sources.list; then
    grep '^deb .*bookworm' /etc/apt/sources.list > "$root/etc/apt/sources.list"
  fi
  # Current against those sources, as Docker Hub's debian:12 is (debootstrap takes bookworm's release).
  cp /etc/resolv.conf "$root/etc/resolv.conf"
  mount -t proc proc "$root/proc"
  chroot "$root" sh -c 'apt-get update -q && DEBIAN_FRONTEND=noninteractive apt-get upgrade -y -q' > "$root.log" 2>&1 \
    || { umount "$root/proc"; tail -20 "$root.log"; exit 1; }
  umount "$root/proc"
  rm -f "$root.log"
  rm -rf "$root"/var/lib/apt/lists/* "$root"/var/cache/apt/archives/*.deb
  # The certificate authorities this machine trusts (a proxy that intercepts TLS, as on some build
  # machines, included), for the build stage's npm ci: one file each where update-ca-certificates keeps
  # them when the build installs ca-certificates, the bundle itself, and Node.js told to read it.
  local env=()
  if [ -f /etc/ssl/certs/ca-certificates.crt ]; then
    mkdir -p "$root/usr/local/share/ca-certificates/host" "$root/etc/ssl/certs"
    awk -v dir="$root/usr/local/share/ca-certificates/host" \
      '/-----BEGIN CERTIFICATE-----/ {n++; f = sprintf("%s/ca-%03d.crt", dir, n)} f {print > f} /-----END CERTIFICATE-----/ {close(f); f = ""}' \
      /etc/ssl/certs/ca-certificates.crt
    cp /etc/ssl/certs/ca-certificates.crt "$root/etc/ssl/certs/ca-certificates.crt"
    env=(--env NODE_EXTRA_CA_CERTS=/etc/ssl/certs/ca-certificates.crt)
  fi
  ctr=$(buildah from scratch)
  buildah copy --quiet "$ctr" "$root" / > /dev/null
  buildah config --cmd /bin/bash --env PATH=/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin "${env[@]}" "$ctr"
  buildah commit --quiet --rm "$ctr" debian:12 > /dev/null
  rm -rf "$root/usr/local/share/ca-certificates/host" "$root/etc/ssl/certs/ca-certificates.crt"
  # slim: without documentation, manuals and translations, as Docker Hub's debian:12-slim.
  rm -rf "$root"/usr/share/doc/* "$root"/usr/share/man/* "$root"/usr/share/info/* "$root"/usr/share/locale/*
  ctr=$(buildah from scratch)
  buildah copy --quiet "$ctr" "$root" / > /dev/null
  buildah config --cmd /bin/bash --env PATH=/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin "$ctr"
  buildah commit --quiet --rm "$ctr" debian:12-slim > /dev/null
  echo "images: base images debian:12 and debian:12-slim in $((SECONDS - t0)) s"
}

if [ "${1:-}" = "--rebuild-base" ] || ! exists debian:12 || ! exists debian:12-slim; then
  make_base
fi

: > "$report"
for target in server worker cli; do
  t0=$SECONDS
  echo "images: building kgd-$target"
  # The build stage compiles kgd for a quarter of an hour on two cores: one heavy build at a time
  # on a shared machine (the later targets reuse its cached layers).
  flock /tmp/kgd-build.lock buildah bud --quiet --layers --pull=never --format docker --isolation chroot --network host \
    -f deploy/docker/Dockerfile --target "$target" -t "kgd-$target" . > /dev/null
  size=$(buildah images --noheading --format '{{.Size}}' "kgd-$target" | head -1)
  line=$(printf 'kgd-%-7s %9s  built in %4d s' "$target" "$size" "$((SECONDS - t0))")
  echo "images: $line"
  echo "$line" >> "$report"
done
