// kinematic_models.cpp — the kinematic model registry (kinematic_models.h).
#include "tools/kinematic_models.h"

#include "tensor/tensor.h"

namespace t2m::cli {

std::vector<KinematicModel>& kinematic_models() {
  static std::vector<KinematicModel> models;
  return models;
}

const KinematicModel& find_kinematic_model(const std::string& name) {
  std::string known = "text2bfm";
  for (const auto& m : kinematic_models()) {
    if (m.name == name) return m;
    known += ", " + m.name;
  }
  throw Error("generate: unknown --model '" + name + "' (known: " + known + ")");
}

}  // namespace t2m::cli
