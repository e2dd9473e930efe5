#!/bin/sh
# insn-count.sh - count the guest instructions between bench_mark_begin() and
# bench_mark_end() of a Cortex-M image under QEMU (plugin: tests/arm/insn_count.c).
#
#   tests/arm/insn-count.sh MACHINE ELF [PLUGIN]
#       MACHINE  mps2-an386 (Cortex-M4F) or microbit (Cortex-M0)
#       PLUGIN   default build/arm/insn-count.so (make arm-count builds it)
#
# Prints the image's own output, then one line per begin/end pair:
#   octo-count: region N: M instructions
# Exit status: QEMU's, i.e. the image's (2 if the plugin printed no count).
# INSN_COUNT_ARGS (environment): more plugin arguments, e.g. "profile=FILE,from=301,every=2"
# (tests/arm/insn-profile.sh uses it).
set -u
machine=$1 elf=$2 plugin=${3:-build/arm/insn-count.so}
sym() { arm-none-eabi-nm "$elf" | awk -v s="$1" '$3 == s { print "0x" $1 }'; }
begin=$(sym bench_mark_begin) end=$(sym bench_mark_end)
if [ -z "$begin" ] || [ -z "$end" ]; then
	echo "insn-count: $elf has no bench_mark_begin/bench_mark_end" >&2
	exit 2
fi
log=$(mktemp)
trap 'rm -f "$log"' EXIT
timeout "${ARM_TIMEOUT:-300}" qemu-system-arm -M "$machine" -nographic -monitor none -serial none \
	-semihosting-config enable=on,target=native \
	-plugin "$plugin,begin=$begin,end=$end,out=$log${INSN_COUNT_ARGS:+,$INSN_COUNT_ARGS}" -kernel "$elf" </dev/null
rc=$?
cat "$log"
grep -q 'instructions$' "$log" || { [ "$rc" = 0 ] && rc=2; }
exit "$rc"
