#pragma once
// pgi: Poisson integrators from symplectic groupoids. The one header a program includes
// (#include <pgi/pgi.hpp>, target pgi::pgi): the Scheme, which owns every exact artefact and the
// compiled step, and the layers below it (series -> poisson -> magnus -> scheme). It leaves out the step's lane
// kernels (poisson/lanes.hpp, lane_step.hpp, batch_step.hpp: GCC vector extensions, internal to the step and the
// ensembles; include them by name to use pgi::BatchStepper). Each layer's internals live in its detail/ folder: no
// public header includes them, and they are not installed.
#include "magnus/magnus.hpp"
#include "magnus/modified_hamiltonian.hpp"
#include "magnus/splitting.hpp"
#include "poisson/hamilton_jacobi.hpp"
#include "poisson/integrate.hpp"
#include "poisson/newton_step.hpp"
#include "poisson/realisation.hpp"
#include "poisson/structure.hpp"
#include "scheme/ensemble.hpp"
#include "scheme/evaluators.hpp"
#include "scheme/input.hpp"
#include "scheme/lyapunov.hpp"
#include "scheme/run_loop.hpp"
#include "scheme/scene.hpp"
#include "scheme/scheme.hpp"
#include "scheme/trajectory.hpp"
#include "series/compile.hpp"
#include "series/latex.hpp"
#include "series/composition.hpp"
#include "series/series.hpp"
#include "scheme/version.hpp"
