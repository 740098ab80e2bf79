// Simbody 3.7 model of a Mechanism (reduced coordinates; see docs/engines.md, "Simbody").
#pragma once

#include <memory>

#include "sim/engine.h"

namespace crosslink::sim {

std::unique_ptr<Engine> make_simbody_engine();

}  // namespace crosslink::sim
