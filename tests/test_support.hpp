// Helpers shared by the tests: temporary directories and small generated flights.
#pragma once

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "tools/sim/scenarios.hpp"
#include "zonemap/ins_gate.hpp"

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

// A whole text file, or "" when it cannot be read.
inline std::string read_text(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}
inline void write_text(const std::string& path, const std::string& text) {
  std::ofstream(path) << text;
}

// A plausible INS solution at time t and position p (valid flags, 0.3 m sigma).
inline InsSolution valid_at(double t, const Eigen::Vector3d& p) {
  InsSolution s;
  s.time_s = t;
  s.position_m = p;
  s.attitude_valid = s.position_valid = true;
  s.position_sigma_m = 0.3;
  return s;
}

inline std::string source_path(const std::string& relative) {
  return std::string(ZONEMAP_SOURCE_DIR) + "/" + relative;
}

// Writes a generated scenario with the paper's camera (640x480: its focal length
// sets Δd of eq. 1, so smaller images would mean a worse sensor) at a low frame
// rate, plus a copy of its config that maps every `pixel_step`-th pixel to keep
// tests fast. Returns the config's path, empty on failure.
inline std::string write_test_scenario(const std::string& name, const std::string& dir,
                                       double rate_hz, int pixel_step, std::size_t max_frames = 0) {
  sim::Scenario scenario;
  std::string error;
  sim::ScenarioOptions options;
  options.width = 640;
  options.frame_rate_hz = rate_hz;
  if (!sim::make_scenario(name, options, &scenario, &error)) return "";
  if (max_frames > 0 && scenario.trajectory.size() > max_frames) {
    scenario.trajectory.resize(max_frames);
  }
  if (!sim::write_sequence(dir, scenario.scene, scenario.camera, scenario.trajectory,
                           sim::RenderOptions{}, &error)) {
    return "";
  }
  std::ifstream in(source_path(scenario.config));
  std::stringstream text;
  text << in.rdbuf();
  std::string config = text.str();
  const std::string key = "pixel_step: 1";
  const auto at = config.find(key);
  if (at == std::string::npos) return "";
  config.replace(at, key.size(), "pixel_step: " + std::to_string(pixel_step));
  const std::string path = dir + "/test-config.yaml";
  std::ofstream(path) << config;
  return path;
}

}  // namespace zonemap::testing
