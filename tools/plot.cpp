#include "tools/plot.hpp"

#include "series/detail/child_process.hpp"
#include "series/message.hpp"
#include "tools/atomic_file.hpp"

#include <fmt/format.h>

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iostream>
#include <limits>
#include <sstream>

namespace pgi {

namespace fs = std::filesystem;

RunSeries::RunSeries(std::size_t steps, std::size_t dim, std::vector<std::string> invariant_names,
                     std::vector<double> scales, std::size_t bins)
    : stride_(std::max<std::size_t>(1, (steps + bins) / bins)), dim_(dim), names_(std::move(invariant_names)),
      scales_(std::move(scales)) {}

void RunSeries::record(std::size_t n, double t, const double* x, const std::vector<double>& invariants) {
    if (n == 0) initial_ = invariants;
    if (n % stride_ == 0 || bins_.empty()) {
        bins_.push_back({t, std::vector<double>(x, x + dim_), std::vector<double>(names_.size(), 0.0),
                         std::vector<double>(names_.size(), t)});
    }
    Bin& b = bins_.back();
    for (std::size_t i = 0; i < names_.size() && i < invariants.size(); ++i) {
        const double e = relative_error(invariants[i], initial_[i], i < scales_.size() ? scales_[i] : 0.0);
        if (!(e <= b.error[i])) {  // NaN too: a non-finite value is a peak to show
            b.error[i] = e;
            b.error_t[i] = t;
        }
    }
}

namespace {

// A private directory (mkdtemp: 0700, an unpredictable name) for gnuplot's data, script and figures, removed with
// everything in it when it goes out of scope. Only names pgi makes in it reach gnuplot.
struct TempDir {
    fs::path path;
    TempDir() {
        std::string pattern = (fs::temp_directory_path() / "pgi-plot-XXXXXX").string();
        if (!::mkdtemp(pattern.data()))
            throw OutputError(std::string("--plot: cannot create a temporary directory (") + std::strerror(errno) +
                              ")");
        path = pattern;
    }
    ~TempDir() {
        std::error_code ec;
        fs::remove_all(path, ec);
    }
};

bool on_path(const std::string& program) {
    const char* path = std::getenv("PATH");
    std::stringstream dirs(path ? path : "/usr/bin:/bin");
    for (std::string d; std::getline(dirs, d, ':');)
        if (!d.empty() && ::access((fs::path(d) / program).c_str(), X_OK) == 0) return true;
    return false;
}

// A gnuplot string expression that gnuplot takes as text only: single-quoted pieces, in which it runs no `command`,
// joined by pgi_q and pgi_at (script_preamble) where s has a quote or an @ (gnuplot expands @macros even inside
// quotes, and its doubled quotes break when two follow each other); control characters (a newline would end the
// command) shown as \xNN.
std::string quoted(const std::string& s) {
    std::string out = "'";
    for (char c : printable(s))
        out += c == '\'' ? std::string("'.pgi_q.'") : c == '@' ? std::string("'.pgi_at.'") : std::string(1, c);
    return out + "'";
}

// Defines the two characters quoted() never writes inside a string literal, as octal escapes: the script holds no raw
// quote or @ of the user's.
constexpr const char* script_preamble = "pgi_q = \"\\047\"; pgi_at = \"\\100\"\n";

// gnuplot runs as every child does (series/detail/child_process.hpp): no shell, its own process group, killed past a
// minute or on a signal, its diagnostics bounded and sanitised.
void run_gnuplot(const fs::path& script) {
    const ChildResult run = run_child({"gnuplot", script.string()},
                                      {.timeout = std::chrono::seconds(60), .output_limit = std::size_t(64) << 10});
    if (run.failure.rfind("cannot be run", 0) == 0)
        throw OutputError("--plot: gnuplot is not installed (Debian: gnuplot-nox)");
    if (!run.ok()) {
        const std::string output = output_tail(run.output);
        throw OutputError("--plot: gnuplot failed: " + run.failure + (output.empty() ? "" : ": " + output));
    }
}

// Copies a figure gnuplot wrote into the private directory to its target, as every output is written (AtomicFile),
// under a name no file has (commit_new): a figure is never replaced.
void publish(const fs::path& figure, const fs::path& target) {
    std::ifstream in(figure, std::ios::binary);
    if (!in || fs::file_size(figure) == 0) throw OutputError("--plot: gnuplot wrote no " + target.string());
    try {
        AtomicFile out(target);
        out.stream() << in.rdbuf();
        out.commit_new();
    } catch (const std::invalid_argument& e) {
        throw OutputError(std::string("--plot: ") + e.what());
    } catch (const OutputError& e) {
        throw OutputError(std::string("--plot: ") + e.what());
    }
}

// The figure's title for the coordinates drawn: the phase portrait when they are all of them, else a projection.
std::string trajectory_title(const RunSeries& s, const std::vector<std::string>& coords,
                             const std::vector<std::size_t>& shown) {
    if (shown.size() == s.dim()) return "phase portrait";
    std::vector<std::string> names;
    for (std::size_t i : shown) names.push_back(coords[i]);
    return fmt::format("projection onto ({})", fmt::join(names, ", "));
}

// The trajectory: an orbit in the plane or in space of the coordinates shown (2 or 3), time series for 1.
std::string trajectory_plot(const RunSeries& s, const std::vector<std::string>& coords,
                            const std::vector<std::size_t>& shown, const std::string& data) {
    const std::string title = "set title title.\": \"." + quoted(trajectory_title(s, coords, shown)) + "\n";
    if (shown.size() == 2)
        return fmt::format(
            "set xlabel {}; set ylabel {}\n{}"
            "plot {} using {}:{} with lines lw 1.5 lc rgb \"#377eb8\" title \"orbit\", "
            "{} every ::0::0 using {}:{} with points pt 7 ps 1.2 lc rgb \"#e41a1c\" title \"x0\"\n",
            quoted(coords[shown[0]]), quoted(coords[shown[1]]), title, quoted(data), shown[0] + 2, shown[1] + 2,
            quoted(data), shown[0] + 2, shown[1] + 2);
    if (shown.size() == 3)
        return fmt::format(
            "set xlabel {}; set ylabel {}; set zlabel {}; set view 60, 35; set ticslevel 0\n{}"
            "splot {} using {}:{}:{} with lines lw 1.2 lc rgb \"#377eb8\" title \"orbit\", "
            "{} every ::0::0 using {}:{}:{} with points pt 7 ps 1.2 lc rgb \"#e41a1c\" title \"x0\"\n",
            quoted(coords[shown[0]]), quoted(coords[shown[1]]), quoted(coords[shown[2]]), title, quoted(data),
            shown[0] + 2, shown[1] + 2, shown[2] + 2, quoted(data), shown[0] + 2, shown[1] + 2, shown[2] + 2);
    std::string out = "set xlabel \"t\"; set ylabel \"coordinates\"\nset key outside right\n" + title + "plot ";
    for (std::size_t i = 0; i < shown.size(); ++i)
        out += fmt::format("{}{} using 1:{} with lines lw 1.2 title {}", i ? ", " : "", quoted(data), shown[i] + 2,
                           quoted(coords[shown[i]]));
    return out + "\n";
}

std::string errors_plot(const RunSeries& s, double dt, const std::string& data, const std::vector<bool>& has_points) {
    std::string out =
        fmt::format("set xrange [{:.17g}:{:.17g}]\n", dt, std::max(2 * dt, s.bins().empty() ? dt : s.bins().back().t)) +
        "set logscale xy; set format x \"1e%L\"; set format y \"1e%L\"\nset xlabel \"t\"; set ylabel \"relative "
        "error\"\n"
        "set key outside top center horizontal\nset title title.\": invariants (largest error per bin of steps)\"\n";
    std::vector<std::string> exact;
    std::string plot;
    const char* colors[] = {"#000000", "#e41a1c", "#377eb8", "#4daf4a", "#984ea3", "#ff7f00", "#a65628", "#f781bf"};
    for (std::size_t i = 0; i < s.invariant_names().size(); ++i) {
        if (!has_points[i]) {
            exact.push_back(s.invariant_names()[i]);
            continue;
        }
        plot += fmt::format("{} index {} using 1:2 with lines lw {} lc rgb \"{}\" title {}, ", quoted(data), i,
                            i == 0 ? 2.0 : 1.5, colors[i % 8], quoted(s.invariant_names()[i]));
    }
    // Brouwer's law: round-off in a conserved quantity of a well-implemented integrator walks like u sqrt(n)
    plot += fmt::format(
        "2.0**-53 * sqrt(x / {:.17g}) with lines dt 2 lw 1.5 lc rgb \"#777777\" title \"round-off floor u sqrt(n), u = "
        "2^-53\"",
        dt);
    if (!exact.empty())
        out += fmt::format("set label 1 {} at graph 0.02, graph 0.04\n",
                           quoted("exactly conserved (error 0): " + fmt::format("{}", fmt::join(exact, ", "))));
    return out + "plot " + plot + "\n";
}

// At most the first six names, for a message.
std::string some_names(const std::vector<std::string>& names) {
    const std::size_t shown = std::min<std::size_t>(names.size(), 6);
    return fmt::format("{}{}", fmt::join(names.begin(), names.begin() + long(shown), ", "),
                       names.size() > shown ? ", ..." : "");
}

// A user's text in a message: at most 40 characters.
std::string clipped(std::string_view s) {
    return s.size() > 40 ? std::string(s.substr(0, 37)) + "..." : std::string(s);
}

// The index of one entry of --plot-coords: a coordinate's name, or its 1-based index.
std::size_t coordinate_index(const std::vector<std::string>& coords, std::string_view entry) {
    const std::string there = fmt::format(" (the coordinates are {}, or 1..{})", some_names(coords), coords.size());
    if (entry.empty()) throw std::invalid_argument("an empty entry" + there);
    if (std::all_of(entry.begin(), entry.end(), [](char c) { return c >= '0' && c <= '9'; })) {
        const std::size_t k = entry.size() > 9 ? 0 : std::stoul(std::string(entry));
        if (k < 1 || k > coords.size())
            throw std::invalid_argument("index " + clipped(entry) + " is out of range" + there);
        return k - 1;
    }
    const auto at = std::find(coords.begin(), coords.end(), entry);
    if (at == coords.end()) throw std::invalid_argument("'" + clipped(entry) + "' is not a coordinate" + there);
    return std::size_t(at - coords.begin());
}

std::string_view trimmed(std::string_view s) {
    while (!s.empty() && s.front() == ' ') s.remove_prefix(1);
    while (!s.empty() && s.back() == ' ') s.remove_suffix(1);
    return s;
}

}  // namespace

std::vector<std::size_t> plot_coordinates(const std::vector<std::string>& coords, std::string_view spec) {
    std::vector<std::size_t> shown;
    if (spec.empty()) {
        for (std::size_t i = 0; i < std::min<std::size_t>(coords.size(), 3); ++i) shown.push_back(i);
        return shown;
    }
    const auto entries = std::count(spec.begin(), spec.end(), ',') + 1;
    if (entries < 2 || entries > 3)
        throw std::invalid_argument(fmt::format(
            "give two or three coordinates, comma-separated names or 1-based indices like {},{} (got {} in '{}')",
            coords.at(0), coords.size() > 1 ? coords[1] : "2", entries, clipped(spec)));
    for (std::size_t start = 0; start <= spec.size();) {
        const std::size_t end = std::min(spec.find(',', start), spec.size());
        const std::string_view entry = trimmed(spec.substr(start, end - start));
        const std::size_t i = coordinate_index(coords, entry);
        if (std::find(shown.begin(), shown.end(), i) != shown.end())
            throw std::invalid_argument("'" + clipped(entry) + "' names coordinate " + coords[i] + " twice");
        shown.push_back(i);
        start = end + 1;
    }
    return shown;
}

std::vector<fs::path> figure_paths(const fs::path& dir, const std::string& name) {
    return {dir / (name + "-trajectory.svg"), dir / (name + "-trajectory.png"), dir / (name + "-errors.svg"),
            dir / (name + "-errors.png")};
}

std::string free_run_name(const fs::path& dir, const std::string& stem) {
    constexpr int max_runs = 999;
    for (int run = 1; run <= max_runs; ++run) {
        const std::string name = run == 1 ? stem : fmt::format("{}-{}", stem, run);
        const auto paths = figure_paths(dir, name);
        std::error_code ec;  // symlink_status: a dangling link is a name taken too
        if (std::none_of(paths.begin(), paths.end(),
                         [&](const fs::path& p) { return fs::exists(fs::symlink_status(p, ec)); }))
            return name;
    }
    throw std::invalid_argument(
        fmt::format("'{}' holds the figures of {} runs of {}: remove some", dir.string(), max_runs, stem));
}

std::vector<fs::path> draw_run(const RunSeries& s, const std::vector<std::string>& coords,
                               const std::vector<std::size_t>& shown, double dt, const std::string& title,
                               const fs::path& dir, const std::string& name) {
    TempDir tmp;
    const fs::path traj = tmp.path / "trajectory.dat", errs = tmp.path / "errors.dat";
    {
        std::ofstream out(traj);
        for (const auto& b : s.bins()) {
            out << fmt::format("{:.17g}", b.t);
            for (double v : b.x) out << fmt::format(" {:.17g}", v);
            out << "\n";
        }
    }
    std::vector<bool> has_points(s.invariant_names().size(), false);
    {
        std::ofstream out(errs);
        for (std::size_t i = 0; i < s.invariant_names().size(); ++i) {
            out << "# " << printable(s.invariant_names()[i]) << "\n";
            for (const auto& b : s.bins())
                if (b.error[i] > 0 && b.error_t[i] > 0) {  // log axes: zero errors (and t = 0) cannot be drawn
                    out << fmt::format("{:.17g} {:.17g}\n", b.error_t[i],
                                       std::isfinite(b.error[i]) ? b.error[i] : 1e300);
                    has_points[i] = true;
                }
            if (!has_points[i]) out << "1 NaN\n";  // an empty block would shift the indices
            out << "\n\n";
        }
    }
    std::vector<fs::path> written;
    std::string script = script_preamble + fmt::format("title = {}\nset grid\nset encoding utf8\n", quoted(title));
    std::vector<std::pair<fs::path, fs::path>> figures;  // (in the private directory, target)
    const std::vector<fs::path> targets = figure_paths(dir, name);
    for (const auto& [figure, body] :
         {std::pair{std::string("trajectory"), trajectory_plot(s, coords, shown, traj.string())},
          std::pair{std::string("errors"), errors_plot(s, dt, errs.string(), has_points)}})
        for (const auto& [ext, terminal] :
             {std::pair{"svg", "svg size 900,560 font \"sans,12\" background \"white\" noenhanced"},
              std::pair{"png", "pngcairo size 900,560 font \"sans,11\" noenhanced"}}) {
            const fs::path out = tmp.path / fmt::format("{}.{}", figure, ext);
            script += fmt::format("reset\nset grid\nset terminal {}\nset output {}\n{}set output\n", terminal,
                                  quoted(out.string()), body);
            figures.push_back({out, targets[figures.size()]});
        }
    {
        std::ofstream out(tmp.path / "plot.gp");
        out << script;
    }
    run_gnuplot(tmp.path / "plot.gp");
    try {
        for (const auto& [figure, target] : figures) {
            publish(figure, target);
            written.push_back(target);
        }
    } catch (const OutputError&) {
        for (const auto& f : written) fs::remove(f);  // this run's own figures: none is left half a set
        throw;
    }
    return written;
}

RunPlot::RunPlot(const Scene& scene, fs::path dir, std::string_view coordinates) : scene_(scene), dir_(std::move(dir)) {
    if (!fs::is_directory(dir_))
        throw SceneError(scene.file, "--plot",
                         "'" + dir_.string() + "' is not an existing directory (create it first)");
    {  // a real file, not access(): root passes access() on read-only file systems and /proc
        const fs::path probe = dir_ / (".pgi_plot_probe" + std::to_string(::getpid()));
        const int fd =
            ::open(probe.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0600);  // never through a link
        const bool writable = fd >= 0;
        if (writable) ::close(fd), ::unlink(probe.c_str());
        if (!writable) throw SceneError(scene.file, "--plot", "cannot write into '" + dir_.string() + "'");
    }
    if (!on_path("gnuplot")) throw SceneError(scene.file, "--plot", "gnuplot is not installed (Debian: gnuplot-nox)");
    if (!scene.x0 || !scene.t_end)
        throw SceneError(scene.file, "--plot", "nothing to plot: the scene has no [run] x0 and t_end");
    try {
        shown_ = plot_coordinates(scene.phase_space().coordinates(), coordinates);
    } catch (const std::invalid_argument& e) {
        throw SceneError(scene.file, "--plot-coords", e.what());
    }
    try {
        name_ = free_run_name(dir_, scene.file.stem().string());
    } catch (const std::invalid_argument& e) {
        throw SceneError(scene.file, "--plot", e.what());
    }
    // Htilde through dt^{method order}: the first power whose term is not zero for the order-k scheme
    modified_upto_ = 2 * ((scene.order + 1) / 2);
    try {
        modified_ = sum_powers(scene.scheme->modified_hamiltonian(modified_upto_), Rational::from_double(scene.dt));
    } catch (const ResourceLimitError& e) {
        say("pgi: " + scene.file.string() + ": --plot: no modified Hamiltonian in the figure (" + e.what() + ")");
    }
}

void RunPlot::attach(IntegrateOptions& options) {
    std::vector<std::string> names{"H"};
    for (const auto& c : scene_.casimirs) {
        std::string text = c.to_string();
        if (text.size() > 28) text = text.substr(0, 25) + "...";
        names.push_back("Casimir " + text);
    }
    if (!options.modified && modified_) options.modified = modified_;
    if (options.modified) names.push_back(fmt::format("modified H through dt^{}", modified_upto_));
    const auto steps = static_cast<std::size_t>(std::ceil(*scene_.t_end / scene_.dt - 1e-9));
    const std::vector<Poly> extra = options.modified ? std::vector<Poly>{*options.modified} : std::vector<Poly>{};
    series_.emplace(steps, scene_.phase_space().dim(), names, invariant_scales(*scene_.scheme, *scene_.x0, extra));
    options.observe = [this](std::size_t n, double t, const Eigen::VectorXd& x, const std::vector<double>& values) {
        series_->record(n, t, x.data(), values);
    };
}

std::vector<fs::path> RunPlot::write() const {
    if (!series_) throw std::logic_error("RunPlot::write before attach");
    const std::string title =
        fmt::format("{} (order {}, dt = {})", scene_.name.empty() ? scene_.file.stem().string() : scene_.name,
                    scene_.order, scene_.dt);
    return draw_run(*series_, scene_.phase_space().coordinates(), shown_, scene_.dt, title, dir_, name_);
}

}  // namespace pgi
