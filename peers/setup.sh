#!/usr/bin/env bash
# Installs what the peers harness needs beyond crates.io: Embree 3 from Debian's packages
# (libembree-dev, which pulls in libembree3-3 and TBB). Safe to run again: it does nothing when
# the package is already there. Uses sudo only when not run as root.
set -euo pipefail

if [ "$(id -u)" -eq 0 ]; then
  SUDO=()
elif command -v sudo >/dev/null 2>&1; then
  SUDO=(sudo)
else
  echo "setup.sh: not root and no sudo; install libembree-dev by hand" >&2
  exit 1
fi

if dpkg-query -W -f='${Status}' libembree-dev 2>/dev/null | grep -q "install ok installed"; then
  echo "libembree-dev is already installed"
else
  "${SUDO[@]}" apt-get update
  "${SUDO[@]}" env DEBIAN_FRONTEND=noninteractive apt-get install -y libembree-dev
fi

header=/usr/include/embree3/rtcore_config.h
version=$(sed -n 's/^#define RTC_VERSION_STRING "\(.*\)"/\1/p' "$header" 2>/dev/null || true)
case "$version" in
  3.*) echo "Embree $version ($header)" ;;
  *)
    echo "setup.sh: expected Embree 3.x in $header, found '${version:-nothing}'" >&2
    exit 1
    ;;
esac
