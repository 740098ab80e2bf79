// The exported MJCF run in MuJoCo 2.2.2, the version crosslink links (tests/mujoco3/check.mjs
// runs the same files in MuJoCo 3): for each definition MuJoCo realises, `crosslink compare
// --export-mjcf`'s scene (sim::mujoco_mjcf at the engine's defaults, its reference the exact one)
// written to OUT_DIR, loaded, started at its keyframe "start" and stepped for one second of
// simulated time. One JSON line each: the file, the steps, and qpos after them.
// Usage: mujoco3_export_run OUT_DIR DEFINITION...
#include <fmt/format.h>
#include <mujoco/mujoco.h>

#include <array>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "analytic/model/loader.h"
#include "methods/engines.h"
#include "methods/registry.h"
#include "sim/mujoco/mujoco_engine.h"

int main(int argc, char** argv) {
  using namespace crosslink;
  if (argc < 3) {
    fmt::print(stderr, "usage: {} OUT_DIR DEFINITION...\n", argv[0]);
    return 2;
  }
  const std::filesystem::path out_dir = argv[1];
  std::filesystem::create_directories(out_dir);
  const auto engine = methods::find_engine("mujoco")->make();
  for (int a = 2; a < argc; ++a) {
    const std::string path = argv[a];
    const Mechanism m = load_mechanism(path);
    std::string why;
    if (!engine->supports(m, &why)) continue;  // not an export MuJoCo realises
    const methods::MethodRun reference = methods::run_reference(m);
    const std::filesystem::path xml =
        out_dir / (std::filesystem::path(path).stem().string() + ".xml");
    try {
      std::ofstream(xml) << sim::mujoco_mjcf(m, reference.trajectory, {});
    } catch (const std::runtime_error& e) {  // no export (several drivers): said, not checked
      fmt::print(stderr, "{}: not exported: {}\n", path, e.what());
      continue;
    }
    std::array<char, 1000> error{};
    mjModel* model = mj_loadXML(xml.c_str(), nullptr, error.data(), error.size());
    if (!model) {
      fmt::print(stderr, "{}: MuJoCo 2.2.2 cannot load its export: {}\n", path, error.data());
      return 1;
    }
    mjData* data = mj_makeData(model);
    const int start = mj_name2id(model, mjOBJ_KEY, "start");
    if (start >= 0) mj_resetDataKeyframe(model, data, start);
    const long steps = std::lround(1.0 / model->opt.timestep);
    for (long s = 0; s < steps; ++s) mj_step(model, data);
    nlohmann::json line{{"definition", path}, {"xml", xml.string()}, {"steps", steps}};
    line["qpos"] = std::vector<double>(data->qpos, data->qpos + model->nq);
    fmt::print("{}\n", line.dump());
    mj_deleteData(data);
    mj_deleteModel(model);
  }
  return 0;
}
