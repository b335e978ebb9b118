#!/usr/bin/env bash
# Runs cvtmesh-gui scripted under Xvfb (Mesa's software OpenGL), then checks the PNG it wrote.
# usage: gui_screenshot_test.sh XVFB_RUN GUI CHECKER [--expect-failure]
#                               [--expect-output REGEX] PNG WIDTH HEIGHT MIN_FRACTION
#                               MIN_COLOURS [GUI ARGUMENTS...]
# With --expect-failure the program must exit non-zero with exactly one line on stderr and
# write no PNG. With --expect-output its standard output must have a line matching REGEX
# (grep -E).
set -uo pipefail
xvfb=$1 gui=$2 checker=$3
shift 3
expect_failure=0
if [ "$1" = --expect-failure ]; then
  expect_failure=1
  shift
fi
expect_output=
if [ "$1" = --expect-output ]; then
  expect_output=$2
  shift 2
fi
png=$1 width=$2 height=$3 fraction=$4 colours=$5
shift 5
mkdir -p "$(dirname "$png")"
rm -f "$png"
stderr=$(mktemp) rcfile=$(mktemp) stdout=$(mktemp)
trap 'rm -f "$stderr" "$rcfile" "$stdout"' EXIT
SECONDS=0
# The program's own exit code goes through a file: xvfb-run sometimes fails to clean up its
# temporary folder after a quick exit and then returns its own code and message instead.
"$xvfb" -a -s "-screen 0 1280x800x24" sh -c '"$@"; echo $? >"$0"' "$rcfile" \
  "$gui" "$@" --screenshot "$png" --exit >"$stdout" 2>"$stderr"
rc=$(cat "$rcfile")
rc=${rc:-99}
grep -v '^xvfb-run: ' "$stderr" >"$stderr.own" || true
mv "$stderr.own" "$stderr"
cat "$stdout"
cat "$stderr" >&2
echo "cvtmesh-gui: exit $rc after ${SECONDS} s"
if [ "$expect_failure" = 1 ]; then
  [ "$rc" -ne 0 ] || { echo "FAIL: expected a non-zero exit"; exit 1; }
  lines=$(wc -l <"$stderr")
  [ "$lines" -eq 1 ] || { echo "FAIL: expected one line on stderr, got $lines"; exit 1; }
  grep -q '^cvtmesh-gui: ' "$stderr" || { echo "FAIL: the line does not start with cvtmesh-gui:"; exit 1; }
  [ ! -e "$png" ] || { echo "FAIL: a screenshot was written"; exit 1; }
  exit 0
fi
[ "$rc" -eq 0 ] || { echo "FAIL: cvtmesh-gui exited with $rc"; exit 1; }
if [ -n "$expect_output" ] && ! grep -Eq "$expect_output" "$stdout"; then
  echo "FAIL: no output line matches '$expect_output'"
  exit 1
fi
exec "$checker" "$png" "$width" "$height" "$fraction" "$colours"
