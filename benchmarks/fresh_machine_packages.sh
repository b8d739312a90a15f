#!/usr/bin/env bash
# The package part of a fresh machine, timed: for each set (scripts/setup --demo, then scripts/setup),
# a new Debian 12 root made by debootstrap (minbase), a clone of this repository's HEAD in it, and
# scripts/setup run inside, timed to its exit. Run as root on a Debian machine, one set after the
# other so both see the same mirror and load:
#   benchmarks/fresh_machine_packages.sh [ROOT_DIR (/var/tmp/fresh-root)]
# The host's apt sources, DNS settings and extra CA certificates (/usr/local/share/ca-certificates,
# for a network behind a TLS proxy) and npm settings are copied in; nothing else of the host is.
set -euo pipefail
top=$(cd "$(dirname "$0")/.." && pwd)
root=${1:-/var/tmp/fresh-root}
[ "$(id -u)" -eq 0 ] || { echo "fresh_machine_packages.sh: needs root (debootstrap, chroot)" >&2; exit 2; }
command -v debootstrap >/dev/null || apt-get install -y -q debootstrap >/dev/null

unmount_all() { for m in sys dev/pts dev proc; do umount "$root/$m" 2>/dev/null || true; done; }
trap unmount_all EXIT

make_root() {
  unmount_all
  rm -rf "$root"
  debootstrap --variant=minbase bookworm "$root" http://deb.debian.org/debian > "$root.debootstrap.log" 2>&1 ||
    { echo "debootstrap failed: $root.debootstrap.log" >&2; exit 1; }
  cp /etc/apt/sources.list.d/* "$root/etc/apt/sources.list.d/" 2>/dev/null || true
  cp /etc/resolv.conf "$root/etc/resolv.conf"
  mkdir -p "$root/usr/local/share/ca-certificates"
  cp /usr/local/share/ca-certificates/* "$root/usr/local/share/ca-certificates/" 2>/dev/null || true
  [ -f "$HOME/.npmrc" ] && cp "$HOME/.npmrc" "$root/root/.npmrc"
  for m in proc dev dev/pts sys; do mount --bind "/$m" "$root/$m"; done
  git clone -q "$top" "$root/work/modal-haptics"
  # git and the CA bundle come first: a fresh machine has them before it has our clone.
  chroot "$root" bash -c 'apt-get update -q >/dev/null && apt-get install -y -q --no-install-recommends git ca-certificates >/dev/null 2>&1 && update-ca-certificates >/dev/null 2>&1'
}

for set in --demo ""; do
  make_root
  name=${set:-full}
  chroot "$root" bash -c "cd /work/modal-haptics && start=\$(date +%s) && scripts/setup $set > /tmp/setup.log 2>&1; status=\$?; \
    echo \"scripts/setup ${set:-(everything)}: exit \$status after \$(( \$(date +%s) - start )) s, \$(dpkg -l | grep -c '^ii') packages installed\""
  cp "$root/tmp/setup.log" "$root.setup-${name#--}.log"
done
