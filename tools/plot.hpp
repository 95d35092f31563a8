#pragma once
// Figures of a run, drawn by gnuplot (pngcairo and svg terminals): the trajectory (a phase portrait for two
// or three coordinates, time series otherwise) and the relative errors of H, the Casimirs and the modified
// Hamiltonian against t on log axes, with the round-off floor u sqrt(n). gnuplot is the project's one
// plotting tool: it needs no Python, so the CLI draws on its own, and the Python library can call this code.
#include "tools/commands.hpp"

#include <filesystem>
#include <string>
#include <vector>

namespace pgi {

/// A run thinned to at most `bins` points: the steps fall into equal bins; each bin keeps its first state
/// (the trajectory) and, for every invariant, its largest relative error and when (so no peak is lost).
class RunSeries {
public:
    /// scales: each invariant's size at x0 (invariant_scales), what its relative error divides by.
    RunSeries(std::size_t steps, std::size_t dim, std::vector<std::string> invariant_names, std::vector<double> scales,
              std::size_t bins = 2000);
    /// Step n (0 = the initial state) at time t: the state and the invariants' values.
    void record(std::size_t n, double t, const double* x, const std::vector<double>& invariants);

    struct Bin {
        double t = 0;
        std::vector<double> x;
        std::vector<double> error, error_t;  // per invariant: the bin's largest relative error and its time
    };
    const std::vector<Bin>& bins() const { return bins_; }
    const std::vector<std::string>& invariant_names() const { return names_; }
    std::size_t dim() const { return dim_; }

private:
    std::size_t stride_, dim_;
    std::vector<std::string> names_;
    std::vector<double> scales_, initial_;
    std::vector<Bin> bins_;
};

/// The two figures NAME-trajectory and NAME-errors, each as .svg and .png in dir, written beside their
/// targets and renamed into place. coordinates names the state's components (LaTeX-free), dt the step
/// (the round-off floor u sqrt(t/dt)). Returns the files written. Throws std::runtime_error when gnuplot
/// fails or is missing.
std::vector<std::filesystem::path> draw_run(const RunSeries& series, const std::vector<std::string>& coordinates,
                                            double dt, const std::string& title, const std::filesystem::path& dir,
                                            const std::string& name);

/// pgi run/integrate --plot DIR: checks DIR and gnuplot before the run (SceneError: exit 2), adds the
/// modified Hamiltonian through dt^{method order} to what the run watches, records the run, draws it.
class RunPlot {
public:
    RunPlot(const Scene& scene, std::filesystem::path dir);
    /// Sets options.modified (unless set) and options.observe to record into this plot.
    void attach(IntegrateOptions& options);
    /// After a successful run: the figures (see draw_run).
    std::vector<std::filesystem::path> write() const;

private:
    const Scene& scene_;
    std::filesystem::path dir_;
    std::optional<Poly> modified_;
    std::size_t modified_upto_ = 0;
    std::optional<RunSeries> series_;
};

}  // namespace pgi
