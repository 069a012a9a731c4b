// Helpers shared by the tests: temporary directories and small generated flights.
#pragma once

#include <cstdlib>
#include <filesystem>
#include <string>

#include "tools/sim/scenarios.hpp"

namespace zonemap::testing {

class TempDir {
 public:
  TempDir() {
    std::string pattern = (std::filesystem::temp_directory_path() / "zonemap-test-XXXXXX").string();
    path_ = mkdtemp(pattern.data());
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  const std::string& path() const { return path_; }
  std::string operator/(const std::string& name) const { return path_ + "/" + name; }

 private:
  std::string path_;
};

inline std::string source_path(const std::string& relative) {
  return std::string(ZONEMAP_SOURCE_DIR) + "/" + relative;
}

// Writes a generated scenario (small images, low frame rate) and returns its config path.
inline std::string write_small_scenario(const std::string& name, const std::string& dir, int width,
                                        double rate_hz, std::size_t max_frames = 0) {
  sim::Scenario scenario;
  std::string error;
  sim::ScenarioOptions options;
  options.width = width;
  options.frame_rate_hz = rate_hz;
  if (!sim::make_scenario(name, options, &scenario, &error)) return "";
  if (max_frames > 0 && scenario.trajectory.size() > max_frames) {
    scenario.trajectory.resize(max_frames);
  }
  if (!sim::write_sequence(dir, scenario.scene, scenario.camera, scenario.trajectory,
                           sim::RenderOptions{}, &error)) {
    return "";
  }
  return source_path(scenario.config);
}

}  // namespace zonemap::testing
