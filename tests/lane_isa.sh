#!/bin/bash
# Two files are compiled for AVX2 and run only where the processor has it: poisson/lane_step_avx2.cpp (the batch
# step's Pack4 kernels) and series/compile_avx2.cpp (CompiledMap's groups as one vector of four,
# eval_groups_avx2). Checks each object: (1) its kernels do use AVX2 registers (the flag took effect), (2) no other
# function the object exports (global or weak: an inline function other files also emit, which the linker may keep
# for the whole program) contains an AVX instruction, which would fault on a processor without AVX where that copy
# runs outside the AVX2 path.
# Usage: lane_isa.sh BUILD_DIR
set -euo pipefail

# check OBJECT_NAME KERNELS_REGEX
check() {
    local object exported report ymm bad count
    object=$(find "$BUILD" -name "$1" -print -quit)
    [ -n "$object" ] || { echo "lane_isa: no $1 under $BUILD" >&2; exit 1; }
    exported=$(mktemp)
    nm -C --defined-only --extern-only "$object" | grep -E ' [TWu] ' | sed -E 's/^[0-9a-f]+ [TWu] //' | sort -u >"$exported"
    report=$(objdump -d --no-show-raw-insn -C "$object" | awk -v exported="$exported" -v kernels="$2" '
        BEGIN { while ((getline line < exported) > 0) keep[line] = 1 }
        /^[0-9a-f]+ <.*>:$/ { name = $0; sub(/^[0-9a-f]+ </, "", name); sub(/>:$/, "", name); next }
        /^ +[0-9a-f]+:\t/ {
            split($0, f, "\t"); insn = f[2]
            kernel = name ~ kernels
            if (kernel && insn ~ /%ymm/) ymm++
            if (!kernel && (name in keep) && insn ~ /^v[a-z0-9]+ /) bad[name] = 1
        }
        END { print "ymm " ymm + 0; for (n in bad) print "bad " n }')
    count=$(wc -l <"$exported")
    rm -f "$exported"
    ymm=$(sed -n 's/^ymm //p' <<<"$report")
    bad=$(sed -n 's/^bad //p' <<<"$report")
    [ "$ymm" -gt 0 ] || { echo "lane_isa: the kernels in $object use no AVX2 register: -mavx2 did not apply" >&2; exit 1; }
    if [ -n "$bad" ]; then
        echo "lane_isa: functions exported by $object contain AVX instructions (and may be the program's copy):" >&2
        echo "$bad" >&2
        exit 1
    fi
    echo "lane_isa: $ymm AVX2 instructions in the kernels of $1; $count exported symbols, none other with AVX"
}

# check_program BINARY: the program's Pack4 kernels (LaneStep<N, Pack4>'s round and step) are the AVX2 file's: a copy
# compiled elsewhere for the baseline (a unity build's neighbour of lane_step.cpp once made one), which the linker
# may keep instead, has no AVX2 register.
check_program() {
    local report
    [ -f "$1" ] || { echo "lane_isa: no program $1" >&2; exit 1; }
    report=$(objdump -d --no-show-raw-insn -C "$1" | awk '
        /^[0-9a-f]+ <.*>:$/ {
            name = $0; sub(/^[0-9a-f]+ </, "", name); sub(/>:$/, "", name)
            kernel = name ~ /^pgi::LaneStep<[0-9], pgi::lanes::PackOf<4ul> >::(round|step)\(/
            if (kernel) ymm[name] += 0
            next
        }
        kernel && /%ymm/ { ymm[name]++ }
        END { for (n in ymm) print ymm[n] " " n }')
    [ -n "$report" ] || { echo "lane_isa: $1 holds no LaneStep<N, Pack4> kernel" >&2; exit 1; }
    if grep -q '^0 ' <<<"$report"; then
        echo "lane_isa: $1 keeps a copy of these Pack4 kernels without AVX2 (not lane_step_avx2.cpp's):" >&2
        grep '^0 ' <<<"$report" | cut -d' ' -f2- >&2
        exit 1
    fi
    echo "lane_isa: the $(wc -l <<<"$report") Pack4 kernels in $1 are the AVX2 ones"
}

BUILD=$1
check lane_step_avx2.cpp.o 'PackOf<4ul>|MaskOf<4ul>'
check compile_avx2.cpp.o 'eval_groups|QuadSums'
check_program "$BUILD/pgi"
