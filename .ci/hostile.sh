#!/usr/bin/env bash
# The hostile-input suite: every file of .ci/hostile_corpus.py through every subcommand
# that reads a mesh, each under a 4 GB address-space cap and a 30 s limit. Asserts: no
# panic, no crash, no time-out; `ok-*` files succeed; `error-*` and `refuse-*` files fail
# with an error that names the file (`refuse-*`: and says which reference it refuses);
# nothing outside the asset's folder is read (the canary's value never shows up).
set -uo pipefail
rtmesh="$(realpath "${RTMESH:-target/release/rtmesh}")"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
python3 "$(dirname "$0")/hostile_corpus.py" "$work"
cd "$work/asset"
subcommands=(
  "info"
  "lint"
  "pair"
  "repair --size 64x64 --runs 1"
  "trace --size 64x64 --runs 1"
  "render -o $work/out.png --size 64x48"
  "convert $work/out.glb"
  "convert $work/converted/FILE/out.obj"
  "optimize -o $work/optimized.glb --size 64x64 --runs 1"
  "strip -o $work/strips.ply"
  "strip --partition morton -o $work/morton-strips.ply"
  "strip --method meshopt -o $work/meshopt-strips.ply"
  "cluster --method contract"
  "cluster --method meshopt"
  "dynamic --motion explode --frames 2 --size 16x16 --runs 1 --method contract"
)
checked=0 failed=0
for file in *.obj *.ply *.gltf *.glb *.stl; do
  for subcommand in "${subcommands[@]}"; do
    read -r -a words <<< "$subcommand"
    # FILE: a folder of its own for each input's output (an OBJ's library beside it).
    words=("${words[@]//FILE/$file}")
    mkdir -p "$work/converted/$file"
    out="$( (ulimit -v 4194304; timeout 30 "$rtmesh" "${words[0]}" "$file" "${words[@]:1}" --json) 2> "$work/stderr")"
    rc=$?
    err="$(cat "$work/stderr")"
    checked=$((checked + 1))
    problem=""
    case "$rc" in
      0|1) ;;
      124) problem="timed out after 30 s" ;;
      *) problem="exit code $rc (panic, abort or out of memory)" ;;
    esac
    if grep -q "panicked" <<< "$err"; then problem="panicked"; fi
    case "$file" in
      ok-*) [ "$rc" = 0 ] || problem="${problem:-failed: $err}" ;;
      error-*) { [ "$rc" = 1 ] && grep -q "$file" <<< "$err"; } || problem="${problem:-expected an error naming the file, got rc $rc: $err}" ;;
      refuse-*) { [ "$rc" = 1 ] && grep -q "$file" <<< "$err" && grep -q "refers to" <<< "$err"; } || problem="${problem:-expected a refused reference, got rc $rc: $err}" ;;
    esac
    if grep -q "12345.5" <<< "$out"; then problem="the canary outside the folder was read"; fi
    if [ -n "$problem" ]; then
      echo "FAIL $file / ${words[0]}: $problem"
      failed=$((failed + 1))
    fi
  done
done
# Amplification, where the answer depends on the subcommand: WANT is ok, or the words
# the error must hold (besides the file's name).
expect() {
  local file="$1" want="$2"
  shift 2
  out="$( (ulimit -v 4194304; timeout 30 "$rtmesh" "$1" "$file" "${@:2}" --json) 2> "$work/stderr")"
  rc=$?
  err="$(cat "$work/stderr")"
  checked=$((checked + 1))
  if [ "$want" = ok ]; then
    [ "$rc" = 0 ] || problem="expected success, got rc $rc: $err"
  else
    { [ "$rc" = 1 ] && grep -q "$file" <<< "$err" && grep -q "$want" <<< "$err"; } \
      || problem="expected an error naming the file with '$want', got rc $rc: $err"
  fi
  if [ -n "${problem:-}" ]; then
    echo "FAIL $file / $*: $problem"
    failed=$((failed + 1))
    problem=""
  fi
}
expect amp-instances.gltf ok trace --size 64x64 --runs 1
expect amp-instances.gltf ok convert "$work/instances.glb"
expect amp-instances.gltf "cannot flatten" strip
expect amp-instances.gltf "cannot flatten" trace --leaf strip --size 64x64 --runs 1
expect amp-instances.gltf "cannot flatten" convert "$work/instances.obj"
expect amp-instances.gltf "cannot flatten" convert "$work/instances.ply"
expect amp-channels.gltf ok info
expect amp-obj-mtllib-respelled.obj "material libraries hold over" info
expect amp-channels.gltf "over and over" dynamic --motion gltf --frames 2 --size 16x16 --runs 1
expect amp-channels.gltf "over and over" animate --motion gltf --frames 2 -o "$work/frames"
# No file any command wrote holds the canary's bytes (a copied or stored image).
checked=$((checked + 1))
if ! python3 - "$work" <<'PY'
import os, sys
work = sys.argv[1]
canary = open(os.path.join(work, "canary.bin"), "rb").read()
for folder, _, names in os.walk(work):
    if os.path.abspath(folder).startswith(os.path.join(work, "asset")):
        continue
    for name in names:
        path = os.path.join(folder, name)
        if path != os.path.join(work, "canary.bin") and not os.path.islink(path):
            if canary in open(path, "rb").read():
                sys.exit(f"{path} holds the canary")
PY
then
  echo "FAIL: a written file holds the canary"
  failed=$((failed + 1))
fi
files=$(ls *.obj *.ply *.gltf *.glb *.stl | wc -l)
echo "hostile-input suite: $files files x ${#subcommands[@]} subcommands and $((checked - files * ${#subcommands[@]})) checks by subcommand = $checked runs, $failed failed"
[ "$failed" = 0 ]
