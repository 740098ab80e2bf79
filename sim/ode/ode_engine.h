// ODE 0.16 (double precision) model of a Mechanism (see docs/engines.md, "ODE", for the scene and
// its settings).
#pragma once

#include <memory>

#include "sim/engine.h"

namespace crosslink::sim {

std::unique_ptr<Engine> make_ode_engine();

// ODE's process-wide start-up, once: dInitODE2, and its error, debug and message handlers, which
// ODE calls before abort() or exit(): the error and debug handlers throw std::runtime_error with
// ODE's message instead, so an internal error fails the run and never the process. Throws
// std::runtime_error when the library linked is not ODE's double-precision build. Every thread
// that steps a world calls it (it allocates ODE's data for the calling thread too).
void ode_start();

}  // namespace crosslink::sim
