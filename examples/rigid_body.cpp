// The rigid body from strings, through an installed pgi: a Scheme of order 4, 1000 steps of dt = 0.05
// from (0.6, 0.8, 0.3), then the drift of the Casimir |x|^2 and of the energy.
#include <pgi/pgi.hpp>

#include <cmath>
#include <cstdio>

int main() {
    pgi::SchemeValues values;
    values.coordinates = {"x1", "x2", "x3"};
    values.brackets = {{"x1,x2", "-x3"}, {"x2,x3", "-x1"}, {"x3,x1", "-x2"}};
    values.hamiltonian = "x1^2/2 + x2^2/3 + x3^2/4";
    values.casimirs = {"x1^2 + x2^2 + x3^2"};
    values.order = 4;
    const pgi::Scheme scheme = pgi::Scheme::from_values(values);
    scheme.require_valid();

    Eigen::VectorXd x(3);
    x << 0.6, 0.8, 0.3;
    const double dt = 0.05;
    pgi::NewtonStepper stepper = scheme.stepper(dt, x);
    pgi::CompiledMap invariants = scheme.invariants();  // H, then the Casimirs
    double initial[2], value[2];
    invariants.eval(x.data(), initial);
    Eigen::VectorXd increment(3);
    for (int n = 1; n <= 1000; ++n) {
        if (stepper.step(x, increment) != pgi::StepStatus::ok) {
            std::fprintf(stderr, "step %d failed (residual %.3g)\n", n, stepper.last_residual());
            return 3;
        }
        x += increment;
    }
    invariants.eval(x.data(), value);
    std::printf("pgi %s, order %zu (method order %zu), %s realisation\n", std::string(pgi::version()).c_str(),
                scheme.order(), scheme.method_order(), pgi::to_string(scheme.realisation_form()).c_str());
    std::printf("x(50) = (%.12f, %.12f, %.12f)\n", x[0], x[1], x[2]);
    std::printf("Casimir drift %.3e\n", std::abs(value[1] - initial[1]) / initial[1]);
    std::printf("energy drift %.3e\n", std::abs(value[0] - initial[0]) / initial[0]);
    return std::abs(value[1] - initial[1]) / initial[1] < 1e-12 ? 0 : 1;
}
