// zonemap-sim SCENARIO OUT_DIR [--width N] [--rate HZ] [--seed N] [--frames N]
//             [--noise-px S] [--holes F]
// Writes a generated flight in the replay layout (FORMATS.md §1). --noise-px: the
// matching noise applied (eq. 1's sigma in pixels; default 0.125, half of the paper
// camera's 0.25 that the configs assume); --holes: the fraction of pixels dropped at
// random (default 0.02; 8x8 blocks are dropped besides).
#include <cstdio>
#include <cstdlib>
#include <string>

#include "tools/sim/scenarios.hpp"
#include "tools/sim/sequence_writer.hpp"

int main(int argc, char** argv) {
  using namespace zonemap::sim;
  if (argc < 3) {
    std::fprintf(stderr,
                 "usage: zonemap-sim SCENARIO OUT_DIR [--width N] [--rate HZ] [--seed N] "
                 "[--frames N] [--noise-px S] [--holes F]\nscenarios:");
    for (const auto& n : scenario_names()) std::fprintf(stderr, " %s", n.c_str());
    std::fprintf(stderr, "\n");
    return 2;
  }
  ScenarioOptions options;
  RenderOptions render;
  long max_frames = -1;
  for (int i = 3; i < argc; ++i) {
    const std::string arg = argv[i];
    if (i + 1 >= argc) {
      std::fprintf(stderr, "zonemap-sim: %s needs a value\n", arg.c_str());
      return 2;
    }
    const char* value = argv[++i];
    char* end = nullptr;
    if (arg == "--width") {
      options.width = static_cast<int>(std::strtol(value, &end, 10));
    } else if (arg == "--rate") {
      options.frame_rate_hz = std::strtod(value, &end);
    } else if (arg == "--seed") {
      render.seed = std::strtoull(value, &end, 10);
      options.seed = render.seed;
    } else if (arg == "--frames") {
      max_frames = std::strtol(value, &end, 10);
    } else if (arg == "--noise-px") {
      render.noise_sigma_px = std::strtod(value, &end);
    } else if (arg == "--holes") {
      render.hole_fraction = std::strtod(value, &end);
    } else {
      std::fprintf(stderr, "zonemap-sim: unknown option %s\n", arg.c_str());
      return 2;
    }
    if (end == value || *end != '\0') {
      std::fprintf(stderr, "zonemap-sim: bad value '%s' for %s\n", value, arg.c_str());
      return 2;
    }
  }
  if (!(render.noise_sigma_px >= 0.0 && render.noise_sigma_px <= 4.0) ||
      !(render.hole_fraction >= 0.0 && render.hole_fraction <= 0.9)) {
    std::fprintf(stderr, "zonemap-sim: --noise-px must be in [0, 4], --holes in [0, 0.9]\n");
    return 2;
  }
  Scenario scenario;
  std::string error;
  if (!make_scenario(argv[1], options, &scenario, &error)) {
    std::fprintf(stderr, "zonemap-sim: %s\n", error.c_str());
    return 2;
  }
  if (max_frames > 0 && static_cast<std::size_t>(max_frames) < scenario.trajectory.size()) {
    scenario.trajectory.resize(static_cast<std::size_t>(max_frames));
  }
  if (!write_sequence(argv[2], scenario.scene, scenario.camera, scenario.trajectory, render,
                      &error)) {
    std::fprintf(stderr, "zonemap-sim: %s\n", error.c_str());
    return 1;
  }
  std::printf("%s: %zu frames %dx%d -> %s (map it with %s)\n", scenario.description.c_str(),
              scenario.trajectory.size(), scenario.camera.width, scenario.camera.height, argv[2],
              scenario.config.c_str());
  return 0;
}
