#pragma once
// pgi ensemble SCENE: many initial states (an NPY or CSV file, or a seeded sampler) integrated on every
// core, written as NPY and CSV. Built into the pgi program (it registers its options with CLI11).
#include "scheme/run_request.hpp"
#include "scheme/scene.hpp"

#include <cstdint>
#include <string>

namespace CLI {
class App;
}

namespace pgi {

struct EnsembleCommandOptions {
    std::string states;       // --states FILE (.npy or .csv)
    std::string sample, box;  // --sample grid|box|casimir, --box lo,hi
    std::size_t count = 0;    // --count N
    std::uint64_t seed = 0;   // --seed S
    std::size_t threads = 0, chunk = 0, batch = 0;
    std::string params;     // --params FILE (.npy or .csv): one column per parameter, one row per state
    std::string out;        // --out PREFIX
    bool x0_given = false;  // --x0 was given (read only by --sample casimir)
    RunLimits limits;       // --max-steps, --max-output-mb (also the bound on a --states file's size)
};

/// --states, --sample, --count, --seed, --box, --threads, --chunk, --batch, --out on cmd.
void add_ensemble_options(CLI::App* cmd, EnsembleCommandOptions& o);
/// Checks the run's size (plan_run: steps, the sampled count), opens the outputs (none may be an input), reads
/// or samples the states (bad input: InputError; a budget: RunBudgetError; all before any work), runs, writes
/// PREFIX.x0.npy, PREFIX.x.npy, PREFIX.errors.npy and PREFIX.csv, and prints a summary (JSON with json).
/// Returns 0 when every trajectory reached t_end, 3 when any did not (every output is written all the same).
int ensemble_command(const Scene& scene, const EnsembleCommandOptions& o, bool json);

}  // namespace pgi
