#!/bin/bash
# poisson/lane_step_avx2.cpp compiles the batch step's Pack4 kernels for AVX2 (#pragma GCC target), the rest of
# that file for the x86-64 baseline. Checks its object: (1) Pack4's kernels do use AVX2 registers (the pragma
# took effect), (2) no other function the object exports (global or weak: an inline function other files also
# emit, which the linker may keep for the whole program) contains an AVX instruction, which would fault on a
# processor without AVX where that copy runs outside the batch's AVX2 path.
# Usage: lane_isa.sh BUILD_DIR
set -euo pipefail
object=$(find "$1" -name 'lane_step_avx2.cpp.o' -print -quit)
[ -n "$object" ] || { echo "lane_isa: no lane_step_avx2.cpp.o under $1" >&2; exit 1; }
exported=$(mktemp)
trap 'rm -f "$exported"' EXIT
nm -C --defined-only --extern-only "$object" | grep -E ' [TWu] ' | sed -E 's/^[0-9a-f]+ [TWu] //' | sort -u >"$exported"
report=$(objdump -d --no-show-raw-insn -C "$object" | awk -v exported="$exported" '
    BEGIN { while ((getline line < exported) > 0) keep[line] = 1 }
    /^[0-9a-f]+ <.*>:$/ { name = $0; sub(/^[0-9a-f]+ </, "", name); sub(/>:$/, "", name); next }
    /^ +[0-9a-f]+:\t/ {
        split($0, f, "\t"); insn = f[2]
        pack4 = name ~ /PackOf<4ul>|MaskOf<4ul>/
        if (pack4 && insn ~ /%ymm/) ymm++
        if (!pack4 && (name in keep) && insn ~ /^v[a-z0-9]+ /) bad[name] = 1
    }
    END { print "ymm " ymm + 0; for (n in bad) print "bad " n }')
ymm=$(sed -n 's/^ymm //p' <<<"$report")
bad=$(sed -n 's/^bad //p' <<<"$report")
[ "$ymm" -gt 0 ] || { echo "lane_isa: Pack4's kernels in $object use no AVX2 register: the target pragma did not apply" >&2; exit 1; }
if [ -n "$bad" ]; then
    echo "lane_isa: functions exported by $object contain AVX instructions (and may be the program's copy):" >&2
    echo "$bad" >&2
    exit 1
fi
echo "lane_isa: $ymm AVX2 instructions in Pack4's kernels; $(wc -l <"$exported") exported symbols, none other with AVX"
