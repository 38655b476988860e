#!/usr/bin/env bash
# Installs a panelbass .deb into a fresh Debian 12 root and checks that its `panelbass serve` answers
# /api/health there (docs/install.md). As root; the root is made with debootstrap when missing, /proc is
# mounted for the run and unmounted after.
#   bash scripts/deb_chroot_check.sh build/panelbass_0.1.0_amd64.deb /work/chroot-deb
set -euo pipefail
[ $# -eq 2 ] || { echo "usage: deb_chroot_check.sh PACKAGE.deb CHROOT_DIR" >&2; exit 2; }
deb=$(realpath "$1") root=$2
[ -d "$root/etc/apt" ] || debootstrap --variant=minbase bookworm "$root" http://deb.debian.org/debian
cp /etc/resolv.conf "$root/etc/resolv.conf"
cp "$deb" "$root/tmp/panelbass.deb"
mount -t proc proc "$root/proc"
trap 'umount "$root/proc"' EXIT
chroot "$root" /bin/bash -euo pipefail -c '
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -qq
  apt-get install -y -qq /tmp/panelbass.deb curl >/dev/null
  dpkg -s panelbass | grep -E "^(Status|Version):"
  rm -rf /tmp/store
  panelbass serve --port 0 --no-demo --store /tmp/store >/tmp/serve.out 2>/tmp/serve.err &
  pid=$!
  for _ in $(seq 100); do grep -q "serving http" /tmp/serve.out 2>/dev/null && break; sleep 0.1; done
  address=$(sed -n "s/^panelbass: serving \(http[^ ]*\) .*/\1/p" /tmp/serve.out)
  echo "address: $address"
  curl -fsS "${address}api/health"; echo
  curl -fsS "$address" -o /tmp/index.html && grep -q "<html" /tmp/index.html && echo "web UI served from the installed default ($(panelbass serve --help | grep -o "web TEXT=[^ ]*"))"
  kill $pid; wait $pid || true
'
