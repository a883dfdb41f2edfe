# Sourced by the benchmark scripts that compare builds: parses `OUT_DIR LABEL=SANDBOX... [-- REST...]`
# into $out, the array `bins` (LABEL=SANDBOX entries) and the array `rest` (what follows `--`),
# and creates $out.
out="$1"
shift
bins=()
while [ $# -gt 0 ] && [ "$1" != "--" ]; do bins+=("$1"); shift; done
[ $# -gt 0 ] && shift
rest=("$@")
mkdir -p "$out"
