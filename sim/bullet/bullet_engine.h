// Bullet 3.24 (float64) model of a Mechanism (see docs/engines.md for the scene and settings).
#pragma once

#include <memory>
#include <string>

#include "sim/engine.h"

namespace crosslink::sim {

std::unique_ptr<Engine> make_bullet_engine();

}  // namespace crosslink::sim
