#!/usr/bin/env bash
# Test lanes: builds and tests dgmesh inside a minimal Debian root per suite, each with that
# suite's Blender and libraries (trixie: Blender 4.3, sid: Blender 5.x). This machine itself is
# the bookworm lane (Blender 3.4), run by scripts/test.sh directly.
#
#   bash scripts/lanes.sh [SUITE...]            run the lanes (default: trixie sid)
#   bash scripts/lanes.sh --refresh [SUITE...]  make those roots anew (the next run uses them)
#   bash scripts/lanes.sh --prepare [SUITE...]  make the roots that are missing, run nothing
#   bash scripts/lanes.sh --shell SUITE         a shell inside a lane's root (mounts set up)
#   bash scripts/lanes.sh --run SUITE CMD...    copy the tree in, run CMD in /src/dgmesh there
#                                               (e.g. --run sid bash scripts/build.sh)
#
# Roots are made once with debootstrap and cached in $DGMESH_ROOTS (default
# /var/cache/dgmesh/roots), then reused: each run copies the working tree into the root's
# /src/dgmesh (its build folder is kept) and runs `scripts/test.sh --lane` there, which installs
# the suite's packages (scripts/deps.sh), builds and runs the native, python and Blender tests.
# A root that cannot be made (archive unreachable, a package uninstallable in sid that day) skips
# its lane with the reason, loudly, and does not fail the run; any failure inside a root that
# exists does. Exit code: 0 when every lane that ran passed.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
roots=${DGMESH_ROOTS:-/var/cache/dgmesh/roots}
[ "$(id -u)" = 0 ] || { echo "lanes: run as root (debootstrap and chroot need it)" >&2; exit 2; }

mode=run
case "${1:-}" in
  --refresh) mode=refresh; shift ;;
  --prepare) mode=prepare; shift ;;
  --shell) mode=shell; shift ;;
  --run) mode=run_cmd; shift ;;
esac
if [ "$mode" = run_cmd ] || [ "$mode" = shell ]; then
  suites=("${1:?which suite}"); shift
  cmd=("$@")
else
  suites=("$@")
fi
((${#suites[@]})) || suites=(trixie sid)

say() { printf '\n=== lane %s: %s\n' "$1" "$2"; }

# Mounts proc, sys, dev and a private /dev/shm inside root $1; unmount_root undoes it.
mount_root() {
  local r=$1
  unmount_root "$r"  # what a run that was killed left mounted
  mount -t proc proc "$r/proc"
  mount -t sysfs sys "$r/sys"
  mount --rbind /dev "$r/dev"
  mount --make-rslave "$r/dev"
  mount -t tmpfs -o mode=1777 shm "$r/dev/shm"
  cp -L /etc/resolv.conf "$r/etc/resolv.conf" 2>/dev/null || true
}
unmount_root() {
  local r=$1 m
  [[ "$r" == "$roots"/?* ]] || { echo "lanes: not a root: '$r'" >&2; return 1; }
  # Deepest first; lazily, so a process still holding a file does not leave a mount behind.
  for m in $(awk -v r="$r/" 'index($2, r) == 1 { print $2 }' /proc/mounts | sort -r); do
    umount -l "$m" 2>/dev/null || true
  done
}

in_root() {  # in_root ROOT CMD...: runs CMD inside ROOT with a clean environment
  local r=$1; shift
  chroot "$r" /usr/bin/env -i HOME=/root LANG=C.UTF-8 TERM=dumb CI="${CI:-}" \
    PATH=/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin DEBIAN_FRONTEND=noninteractive "$@"
}

# Makes the root for suite $1 (debootstrap, then the suite's packages through scripts/deps.sh).
# Prints the reason and returns non-zero when it cannot.
make_root() {
  local suite=$1 r=$roots/$1 tmp=$roots/$1.new
  rm -rf "$tmp"
  mkdir -p "$roots"
  if ! debootstrap --variant=minbase "$suite" "$tmp" >"$roots/$suite.debootstrap.log" 2>&1; then
    echo "debootstrap $suite failed: $(tail -n 3 "$roots/$suite.debootstrap.log" | tr '\n' ' ')"
    rm -rf "$tmp"; return 1
  fi
  # No service may start inside the root.
  printf '#!/bin/sh\nexit 101\n' >"$tmp/usr/sbin/policy-rc.d"
  chmod +x "$tmp/usr/sbin/policy-rc.d"
  # The archive this machine reaches may serve a Release file past its Valid-Until date (sid's
  # lasts a week); the packages it lists still install.
  echo 'Acquire::Check-Valid-Until "false";' >"$tmp/etc/apt/apt.conf.d/99dgmesh-lane"
  mkdir -p "$tmp/src/dgmesh/scripts"
  cp "$root/scripts/deps.sh" "$tmp/src/dgmesh/scripts/"
  mount_root "$tmp"
  trap "unmount_root '$tmp'" EXIT  # (a subshell: the caller reads the reason) also when killed
  local ok=0
  in_root "$tmp" bash /src/dgmesh/scripts/deps.sh --lane >"$roots/$suite.deps.log" 2>&1 || ok=$?
  unmount_root "$tmp"
  trap - EXIT
  if [ "$ok" != 0 ]; then
    echo "installing the $suite packages failed: $(grep -E '^(E:|deps:)' "$roots/$suite.deps.log" | tail -n 3 | tr '\n' ' ')"
    rm -rf "$tmp"; return 1
  fi
  rm -rf "$r"
  mv "$tmp" "$r"
  touch "$r/.dgmesh-root"
}

# Copies the working tree (tracked and untracked files git does not ignore) into the root's
# /src/dgmesh, keeping its build folder and data cache, and the portable package's zips (dist/,
# built on this machine by scripts/package.sh) for the lane's install test. The copies keep their
# modification times, so the build folder can hold an object newer than an edit made while an
# earlier copy was building (a run stopped mid-build, or edits during a run) and skip it: the files
# whose content differs from the last copy's (checksums kept in the build folder) get the current
# time instead, and are rebuilt.
copy_tree() {
  local dest=$1/src/dgmesh list sums
  mkdir -p "$dest"
  find "$dest" -mindepth 1 -maxdepth 1 ! -name build ! -name .cache -exec rm -rf {} +
  list=$(mktemp)
  (cd "$root" && git ls-files -z --cached --others --exclude-standard |
    xargs -0 -r sh -c 'for f; do [ -e "$f" ] && printf "%s\0" "$f"; done' sh) >"$list"
  (cd "$root" && tar --null -T "$list" -cf -) | tar -xf - -C "$dest"
  if [ -d "$dest/build" ]; then
    sums=$dest/build/.copied.sha1
    (cd "$dest" && xargs -0 -r sha1sum -- <"$list") >"$sums.new"
    if [ -f "$sums" ]; then
      sort "$sums" | comm -13 - <(sort "$sums.new") | cut -c43- | (cd "$dest" && xargs -r -d '\n' touch --)
    else
      (cd "$dest" && xargs -0 -r touch -- <"$list")
    fi
    mv "$sums.new" "$sums"
  fi
  rm -f "$list"
  if compgen -G "$root/dist/*-linux-x64*.zip" >/dev/null; then
    mkdir -p "$dest/dist" && cp "$root"/dist/*-linux-x64*.zip "$dest/dist/"
  fi
}

status=0
summary=()
for suite in "${suites[@]}"; do
  r=$roots/$suite
  if [ "$mode" = refresh ] || [ ! -f "$r/.dgmesh-root" ]; then
    say "$suite" "making the root in $r (debootstrap $suite, then its packages)"
    start=$SECONDS
    if ! reason=$(make_root "$suite"); then
      printf '\n!!! lane %s SKIPPED: its root could not be made: %s\n' "$suite" "$reason"
      summary+=("$suite: SKIPPED ($reason)")
      continue
    fi
    echo "root made in $((SECONDS - start)) s"
  fi
  if [ "$mode" = refresh ] || [ "$mode" = prepare ]; then summary+=("$suite: root ready"); continue; fi
  copy_tree "$r"
  mount_root "$r"
  trap 'unmount_root "$r"' EXIT
  if [ "$mode" = shell ]; then
    in_root "$r" bash -c 'cd /src/dgmesh && exec bash -i' || true
  elif [ "$mode" = run_cmd ]; then
    in_root "$r" bash -c 'cd /src/dgmesh && exec "$@"' sh "${cmd[@]}" || status=$?
  else
    say "$suite" "build and test inside $r"
    start=$SECONDS
    if in_root "$r" bash /src/dgmesh/scripts/test.sh --lane "$suite"; then
      summary+=("$suite: passed in $((SECONDS - start)) s")
    else
      summary+=("$suite: FAILED after $((SECONDS - start)) s")
      status=1
    fi
  fi
  unmount_root "$r"
  trap - EXIT
done

printf '\n=== lanes\n'
printf '%s\n' "${summary[@]}"
exit $status
