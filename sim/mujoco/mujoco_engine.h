// MuJoCo 2.2.2 model of a Mechanism (see docs/engines.md for the scene and its settings).
#pragma once

#include <memory>
#include <string>

#include "sim/engine.h"

namespace crosslink::sim {

std::unique_ptr<Engine> make_mujoco_engine();

}  // namespace crosslink::sim
