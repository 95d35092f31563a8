#!/bin/bash
# The AVX2 lane kernels (poisson/lane_step_avx2.cpp, compiled with -mavx2) may define weak symbols only for
# their own Pack4 instantiations: any other inline function compiled there carries AVX2 instructions, and the
# linker could keep that copy for the whole program, which would then fault on a processor without AVX2.
# Usage: lane_isa.sh BUILD_DIR
set -euo pipefail
object=$(find "$1" -name 'lane_step_avx2.cpp.o' -print -quit)
[ -n "$object" ] || { echo "lane_isa: no lane_step_avx2.cpp.o under $1" >&2; exit 1; }
weak=$(nm -C --defined-only "$object" | grep -E ' [WVu] ' || true)
[ -n "$weak" ] || { echo "lane_isa: no weak symbol at all in $object: is it still the lane kernels?" >&2; exit 1; }
others=$(grep -v -e 'PackOf<4' -e 'MaskOf<4' -e 'Pack4' -e 'DW.ref.__gxx_personality_v0' <<<"$weak" || true)
if [ -n "$others" ]; then
    echo "lane_isa: $object defines weak symbols that are not Pack4's (compiled with AVX2, shared with the rest):" >&2
    echo "$others" >&2
    exit 1
fi
echo "lane_isa: $(wc -l <<<"$weak") weak symbols in $object, all Pack4's"
