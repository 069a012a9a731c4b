// The paper's three flight scenarios (§V), generated: (1) a line of bushes and a
// small aircraft, low flight; (2) a line of trees crossed at altitude; (3) two
// posts 7 m apart, flown through and flown around nose-to-centre.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "tools/sim/scene.hpp"

namespace zonemap::sim {

struct Scenario {
  std::string name;
  std::string description;
  std::string config;  // the config/ file made for it
  Scene scene;
  CameraModel camera;
  std::vector<TimedPose> trajectory;
};

struct ScenarioOptions {
  int width = 640;  // image width; height is 3/4 of it (the paper's 640x480)
  double frame_rate_hz = 10.0;
  std::uint64_t seed = 1;  // varies the hard scenes' sizes and gaps (and the rendering noise)
};

// The paper's stereo camera: 30 cm baseline, about 51 x 40 degrees, 1/4 pixel
// matching uncertainty; depth PNG in millimetres.
CameraModel paper_camera(int width);

std::vector<std::string> scenario_names();
bool make_scenario(const std::string& name, const ScenarioOptions& options, Scenario* scenario,
                   std::string* error);

}  // namespace zonemap::sim
