#pragma once
// Figures of a run, drawn by gnuplot (pngcairo and svg terminals): the trajectory (a phase portrait for two
// or three coordinates, a projection onto two or three of them otherwise) and the relative errors of H, the
// Casimirs and the modified Hamiltonian against t on log axes, with the round-off floor u sqrt(n). gnuplot is
// the project's one plotting tool: it needs no Python, so the CLI draws on its own. A run's figures never
// replace earlier ones: a second run of a scene into the same directory gets the next free name.
#include "tools/commands.hpp"

#include <filesystem>
#include <string>
#include <string_view>
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

/// The coordinates the trajectory figure draws, as indices: those spec names ("x1,x3" or "1,3": two or three
/// distinct names or 1-based indices, comma-separated), or for an empty spec the first three (all of them when
/// there are fewer). Throws std::invalid_argument naming the problem and the coordinates there are.
std::vector<std::size_t> plot_coordinates(const std::vector<std::string>& coordinates, std::string_view spec);

/// The figures' files for the run called name: name-trajectory and name-errors, each .svg and .png, in dir.
std::vector<std::filesystem::path> figure_paths(const std::filesystem::path& dir, const std::string& name);

/// stem, else stem-2, stem-3, ...: the first name whose figures (figure_paths) are all absent from dir. Throws
/// std::invalid_argument when dir already holds the figures of 999 runs of stem.
std::string free_run_name(const std::filesystem::path& dir, const std::string& stem);

/// The two figures of figure_paths(dir, name), each written beside its target and given its name only if no
/// file has it (AtomicFile::commit_new: no figure is ever replaced). coordinates names the state's components
/// (LaTeX-free), shown the indices drawn (plot_coordinates), dt the step (the round-off floor u sqrt(t/dt)).
/// Returns the files written. Throws OutputError when gnuplot fails or is missing or a name was taken
/// meanwhile, leaving none of this run's figures behind.
std::vector<std::filesystem::path> draw_run(const RunSeries& series, const std::vector<std::string>& coordinates,
                                            const std::vector<std::size_t>& shown, double dt, const std::string& title,
                                            const std::filesystem::path& dir, const std::string& name);

/// pgi run/integrate --plot DIR [--plot-coords C]: checks DIR, gnuplot and C before the run (SceneError: exit
/// 2), names the run's figures (free_run_name of the scene file's stem), adds the modified Hamiltonian through
/// dt^{method order} to what the run watches, records the run, draws it.
class RunPlot {
public:
    RunPlot(const Scene& scene, std::filesystem::path dir, std::string_view coordinates = {});
    /// The name the figures will have: the scene file's stem, or stem-2, stem-3, ... (see free_run_name).
    const std::string& name() const { return name_; }
    /// Sets options.modified (unless set) and options.observe to record into this plot.
    void attach(IntegrateOptions& options);
    /// After a successful run: the figures (see draw_run).
    std::vector<std::filesystem::path> write() const;

private:
    const Scene& scene_;
    std::filesystem::path dir_;
    std::vector<std::size_t> shown_;
    std::string name_;
    std::optional<Poly> modified_;
    std::size_t modified_upto_ = 0;
    std::optional<RunSeries> series_;
};

}  // namespace pgi
