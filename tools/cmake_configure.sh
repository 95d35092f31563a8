# Sourced by the build scripts: pgi_configure DIR [CMAKE ARGS...] configures the build directory DIR from the source
# root. A fresh DIR uses Ninja when it is installed (deps.sh installs it): Ninja compiles a target's files while the
# libraries it links are still being built, where Make waits for them, so two cores stay busy. A DIR configured before
# keeps its own generator (CMake refuses to change it).
pgi_configure() {
    local dir=$1
    shift
    local generator=()
    if [ ! -f "$dir/CMakeCache.txt" ] && command -v ninja >/dev/null; then generator=(-G Ninja); fi
    cmake -S . -B "$dir" "${generator[@]}" "$@" >/dev/null
}
