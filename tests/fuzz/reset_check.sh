#!/bin/sh
# reset_check.sh BIN DIR...: replays every input of the DIRs through the harness BIN twice in
# one process, in name order and then in reverse, with OCTO_FUZZ_DIGEST set (the harness
# prints a hash of the state each input leaves); fails when an input leaves a different state
# the second time, that is when what an earlier input did leaks into a later one. Empty
# files are left out (the harness ignores them).
bin=$1
shift
files=$(for d in "$@"; do find "$d" -type f -size +0c; done | sort)
[ -n "$files" ] || { echo "reset_check: no inputs in $*"; exit 1; }
rev=$(printf '%s\n' $files | tac)
count=$(printf '%s\n' $files | wc -l)
# shellcheck disable=SC2086 # the names are corpus file names, without blanks
OCTO_FUZZ_DIGEST=1 "$bin" $files $rev 2>&1 | awk -v count="$count" '
	/^Running: / { f = $2 }
	/^digest / {
		n++
		if (!(f in d)) d[f] = $2
		else if (d[f] != $2 && ++bad <= 10) print "reset_check: " f " leaves another state after other inputs"
	}
	END {
		if (n != 2 * count || length(d) != count) { print "reset_check: " n + 0 " digests for " count " inputs run twice"; exit 1 }
		if (bad) { print "reset_check: " bad " of " length(d) " inputs leave another state after other inputs"; exit 1 }
		print "reset_check: " length(d) " inputs, the same state in both orders"
	}'
