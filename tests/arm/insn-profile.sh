#!/bin/sh
# insn-profile.sh - where the instructions of measured regions go, per function.
#
#   tests/arm/insn-profile.sh MACHINE ELF FROM EVERY [TO] [TOP]
#
# Runs the image like insn-count.sh with the counting plugin's profile (regions FROM,
# FROM + EVERY, ... up to TO; TO -1 = all) and prints the TOP (default 15) functions by
# instructions executed in those regions, with their share. A translation block is
# attributed to the function whose symbol (arm-none-eabi-nm) starts at or below it.
# E.g. the experiment steps of tests/bench/step.c (300 HOLD regions, then experiment
# step and app_tick alternating):
#   tests/arm/insn-profile.sh mps2-an386 build/bench/step-m0-fixed.elf 301 2
set -u
machine=$1 elf=$2 from=$3 every=$4 to=${5:--1} top=${6:-15}
prof=$(mktemp) syms=$(mktemp)
trap 'rm -f "$prof" "$syms"' EXIT
INSN_COUNT_ARGS="profile=$prof,from=$from,to=$to,every=$every" \
	tests/arm/insn-count.sh "$machine" "$elf" >/dev/null || exit $?
arm-none-eabi-nm -n -t d "$elf" | awk '$2 ~ /^[TtWw]$/ { print $1 + 0, $3 }' >"$syms"
awk -v top="$top" '
	FNR == NR { a[n] = $1 + 0; s[n] = $2; n++; next }
	{ pc = $1 + 0; lo = 0; hi = n - 1; f = "?"
	  while (lo <= hi) { mid = int((lo + hi) / 2); if (a[mid] <= pc) { f = s[mid]; lo = mid + 1 } else hi = mid - 1 }
	  c[f] += $2; tot += $2 }
	END { printf "   %12d instructions in the profiled regions\n", tot
	      for (k in c) printf "%d %s\n", c[k], k | "sort -rn | head -" top
	      close("sort -rn | head -" top) }' "$syms" "$prof" | \
	awk 'NR == 1 { print; total = $1; next }
	              { printf "   %12d  %5.1f %%  %s\n", $1, 100 * $1 / total, $2 }'
