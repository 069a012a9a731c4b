// Helpers shared by the tests: temporary directories and small generated flights.
#pragma once

#include <unistd.h>

#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <Eigen/Geometry>

#include "core/core_test_support.hpp"  // the split, small config, INS solution
#include "hal/output/obstacle_sink.hpp"
#include "tools/sim/scenarios.hpp"
#include "tools/sim/sequence_writer.hpp"
#include "zonemap/common/config.hpp"
#include "zonemap/common/work_split.hpp"
#include "zonemap/pose/ins_gate.hpp"

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
// A counter a component added to a health snapshot by name; -99 when it is not there.
inline std::int64_t named_value(const hal::HealthSnapshot& health, const std::string& name) {
  for (int i = 0; i < health.named; ++i) {
    if (name == health.names[i]) return health.values[i];
  }
  return -99;
}

inline std::string read_text(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}
inline void write_text(const std::string& path, const std::string& text) {
  std::ofstream(path) << text;
}

// A copy of a sequence with every pose turned about the vertical by 180 degrees:
// the same path with the camera looking back. Returns the copy's path.
inline std::string copy_looking_back(const std::string& sequence, const std::string& copy) {
  std::filesystem::copy(sequence, copy, std::filesystem::copy_options::recursive);
  std::ifstream in(sequence + "/groundtruth.txt");
  std::ofstream out(copy + "/groundtruth.txt");
  const Eigen::Quaterniond turn(Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitZ()));
  for (std::string line; std::getline(in, line);) {
    std::istringstream fields(line);
    double t, x, y, z, qx, qy, qz, qw;
    if (line.empty() || line[0] == '#' || !(fields >> t >> x >> y >> z >> qx >> qy >> qz >> qw)) {
      out << line << "\n";
      continue;
    }
    const Eigen::Quaterniond q = turn * Eigen::Quaterniond(qw, qx, qy, qz);
    out << t << " " << x << " " << y << " " << z << " " << q.x() << " " << q.y() << " " << q.z()
        << " " << q.w() << "\n";
  }
  return copy;
}

inline std::string source_path(const std::string& relative) {
  return std::string(ZONEMAP_SOURCE_DIR) + "/" + relative;
}

// Where generated flights are kept for the other test processes of the same
// build: beside the test binary, under its modification time, so that a rebuilt
// binary (perhaps a changed simulator) never reads an older render. "" when the
// binary cannot be found (the flights are then rendered each time).
inline std::filesystem::path scenario_cache_root() {
  std::error_code ec;
  const std::filesystem::path exe = std::filesystem::read_symlink("/proc/self/exe", ec);
  if (ec) return {};
  const auto stamp = std::filesystem::last_write_time(exe, ec);
  if (ec) return {};
  return exe.parent_path() / "scenario-cache" /
         (exe.filename().string() + "-" +
          std::to_string(static_cast<std::uint64_t>(stamp.time_since_epoch().count())));
}

// Removes the renders of this binary's earlier builds (never the current one's,
// which another test process may be writing).
inline void remove_older_renders(const std::filesystem::path& root) {
  std::error_code ec;
  const std::string binary = root.filename().string();
  const std::string prefix = binary.substr(0, binary.rfind('-') + 1);
  for (const auto& entry : std::filesystem::directory_iterator(root.parent_path(), ec)) {
    const std::string name = entry.path().filename().string();
    if (name != binary && name.rfind(prefix, 0) == 0) std::filesystem::remove_all(entry, ec);
  }
}

// Renders into `dir` through the cache: a flight is rendered once per build (into
// a private directory renamed into place, so racing test processes never see half
// of one) and copied into each test's own directory, which the test may change.
template <typename Render>
bool render_through_cache(const std::string& key, const std::string& dir, Render render) {
  const std::filesystem::path root = scenario_cache_root();
  if (root.empty()) return render(dir);
  const std::filesystem::path entry = root / key;
  std::error_code ec;
  if (!std::filesystem::exists(entry, ec)) {
    if (std::filesystem::create_directories(root, ec)) remove_older_renders(root);
    const std::filesystem::path own = root / (key + ".rendering-" + std::to_string(getpid()));
    if (!render(own.string())) {
      std::filesystem::remove_all(own, ec);
      return false;
    }
    std::filesystem::rename(own, entry, ec);
    if (ec) std::filesystem::remove_all(own, ec);  // another process was first: same bytes
  }
  std::filesystem::copy(entry, dir, std::filesystem::copy_options::recursive, ec);
  return !ec;
}

// The threaded runtime's flights map every 4th pixel; under ThreadSanitizer every
// 8th: the same threads and hand-overs with a quarter of the rays (the mapping is
// what instrumentation slows most).
#ifdef ZONEMAP_TEST_UNDER_TSAN
inline constexpr int kRuntimePixelStep = 8;
#else
inline constexpr int kRuntimePixelStep = 4;
#endif

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
  const std::string key = name + "-" + std::to_string(rate_hz) + "hz-" +
                          std::to_string(scenario.trajectory.size()) + "frames";
  const bool rendered = render_through_cache(key, dir, [&](const std::string& into) {
    return sim::write_sequence(into, scenario.scene, scenario.camera, scenario.trajectory,
                               sim::RenderOptions{}, &error);
  });
  if (!rendered) return "";
  std::ifstream in(source_path(scenario.config));
  std::stringstream text;
  text << in.rdbuf();
  std::string config = text.str();
  const std::string step_key = "pixel_step: 1";
  const auto at = config.find(step_key);
  if (at == std::string::npos) return "";
  config.replace(at, step_key.size(), "pixel_step: " + std::to_string(pixel_step));
  const std::string path = dir + "/test-config.yaml";
  std::ofstream(path) << config;
  return path;
}

}  // namespace zonemap::testing
