#pragma once
// The whole pgi pipeline on one scene text, under a small budget: read, checks, S_1..S_k, the modified
// Hamiltonian, the Magnus series, one step and a few, as `pgi check/terms/modified/magnus/step/integrate`
// run them. Shared by the libFuzzer target (tests/fuzz/fuzz_pipeline.cpp) and the replay of its
// regression seeds (tests/fuzz_regressions.cpp).
//
// Bad input must end in one of pgi's documented refusals (bad input, budget, numerical failure): those are
// caught here and run_pipeline returns which one. Anything else escapes: an internal error, a crash, an
// abort inside FLINT, a sanitizer report or a hang is a finding.
#include "magnus/magnus.hpp"
#include "tools/commands.hpp"
#include "tools/npy.hpp"

#include <algorithm>
#include <string_view>

namespace pgi::fuzz {

enum class Outcome { completed, bad_input, budget, numerical_failure };

// Small enough that an input cannot make the fuzzer run out of time or memory through the exact phase. The time
// budget is each exact call's (the checks, S, the modified Hamiltonian, the Magnus series, the step's build, each
// restarts it): the pipeline's six calls take at most about 6 s of algebra.
inline SceneOverrides small_budget() {
    SceneOverrides o;
    o.max_terms = 20'000;
    o.max_memory_mb = 1024;
    o.max_seconds = 1;
    return o;
}

inline Outcome run_pipeline(std::string_view text) {
    try {
        Scene scene = parse_scene(text, "fuzz.toml", small_budget());
        (void)check_report(scene);
        require_valid(scene);
        scene.order = std::min<std::size_t>(scene.order, 4);  // a small order: the point is reach, not depth
        (void)terms_report(scene);
        (void)modified_report(scene, 2);
        if (scene.magnus_h) (void)magnus_report(scene, 2);
        if (scene.x0) {
            (void)step_report(scene);
            scene.t_end = 3 * scene.dt;  // a few steps
            (void)integrate_report(scene, IntegrateOptions{});
        }
        return Outcome::completed;
    } catch (const ResourceLimitError&) {
        return Outcome::budget;
    } catch (const NumericalFailure&) {
        return Outcome::numerical_failure;
    } catch (const SceneError&) {
        return Outcome::bad_input;
    } catch (const std::invalid_argument&) {
        return Outcome::bad_input;
    }
}

// The polynomial reader alone, in a small ring with a small budget, on the same bytes.
inline Outcome run_parser(std::string_view text) {
    static const auto budget = std::make_shared<const Budget>(
        BudgetLimits{.max_terms = 20'000, .max_bytes = std::size_t{1} << 30, .max_seconds = 1e9});
    static const auto ring = make_ring({"x", "y", "z"}, budget);
    try {
        (void)Poly::parse(ring, text);
        return Outcome::completed;
    } catch (const ResourceLimitError&) {
        return Outcome::budget;
    } catch (const std::invalid_argument&) {
        return Outcome::bad_input;
    }
}

/// An ensemble's states file, read as NPY and as CSV of three columns: parsed, or refused with InputError.
inline Outcome run_states(std::string_view text) {
    const std::string bytes(text);
    Outcome outcome = Outcome::completed;
    for (int kind = 0; kind < 2; ++kind) try {
            (void)(kind == 0 ? parse_npy(bytes, "states.npy") : parse_csv_states(bytes, "states.csv", 3, "x1,x2,x3"));
        } catch (const InputError&) {
            outcome = Outcome::bad_input;
        }
    return outcome;
}

}  // namespace pgi::fuzz
