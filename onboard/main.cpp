// zonemap: the onboard daemon.
//   zonemap --config config/vehicle.yaml [--check-config] [--quiet]
// Frames, poses and outputs as the configuration says; SIGINT/SIGTERM end the run
// cleanly (everything acquired is mapped and published, then boxes.csv and
// stats.json are written). --check-config loads and checks everything, opens
// every file, reserves every buffer, prints the start-up report and exits.
#include <atomic>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <string>

#include "hal/os/realtime.hpp"
#include "onboard/daemon.hpp"

namespace {

std::atomic<zonemap::onboard::VehicleDaemon*> g_daemon{nullptr};

extern "C" void on_signal(int) {
  // Lock-free atomic stores only: async-signal-safe.
  if (auto* d = g_daemon.load()) d->stop();
}

int usage() {
  std::fprintf(stderr, "usage: zonemap --config VEHICLE.yaml [--check-config] [--quiet]\n");
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  if (std::string cpu_problem; !zonemap::os::cpu_runs_this_build(&cpu_problem)) {
    std::fprintf(stderr, "%s: %s\n", argv[0], cpu_problem.c_str());
    return 2;
  }
  std::string config_path;
  bool check_only = false, quiet = false;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--config" && i + 1 < argc) {
      config_path = argv[++i];
    } else if (arg == "--check-config") {
      check_only = true;
    } else if (arg == "--quiet") {
      quiet = true;
    } else {
      return usage();
    }
  }
  if (config_path.empty()) return usage();
  zonemap::onboard::VehicleConfig config;
  std::string error;
  if (!zonemap::onboard::load_vehicle_config(config_path, &config, &error)) {
    std::fprintf(stderr, "zonemap: %s\n", error.c_str());
    return 1;
  }
  zonemap::onboard::VehicleDaemon daemon;
  if (!daemon.open(config, &error)) {
    std::fprintf(stderr, "zonemap: %s\n", error.c_str());
    return 1;
  }
  if (!quiet || check_only) std::fputs(daemon.describe().c_str(), stderr);
  if (check_only) {
    std::fprintf(stderr, "zonemap: %s: configuration OK\n", config_path.c_str());
    return 0;
  }
  g_daemon.store(&daemon);
  struct sigaction action {};
  action.sa_handler = on_signal;
  sigemptyset(&action.sa_mask);
  sigaction(SIGINT, &action, nullptr);
  sigaction(SIGTERM, &action, nullptr);
  daemon.run();
  g_daemon.store(nullptr);
  if (!daemon.write_outputs(&error)) {
    std::fprintf(stderr, "zonemap: %s\n", error.c_str());
    return 1;
  }
  const auto& s = daemon.pipeline_stats();
  if (!quiet) {
    std::fprintf(stderr,
                 "zonemap: %s: %lld frames in, %lld mapped, %lld rejected, %lld without pose, "
                 "%lld dropped; end-to-end p50 %.1f ms, p99 %.1f ms; allocations after init %lld\n",
                 s.stopped ? "stopped" : "done", static_cast<long long>(s.frames_in),
                 static_cast<long long>(s.frames_mapped), static_cast<long long>(s.frames_rejected),
                 static_cast<long long>(s.frames_skipped_no_pose),
                 static_cast<long long>(s.dropped_mapper_behind + s.dropped_pool_full),
                 s.end_to_end.percentile(0.5), s.end_to_end.percentile(0.99),
                 static_cast<long long>(s.mapping_thread_allocations + s.output_thread_allocations +
                                        s.ins_thread_allocations));
    if (s.frames_ground_below_environment > 0) {
      std::fprintf(stderr,
                   "zonemap: warning: in %lld of %lld frames most of what the camera measured lies "
                   "under the environment: the ground and the lower part of what stands on it are "
                   "not mapped (map.environment, above_camera_m, zone_cells)\n",
                   static_cast<long long>(s.frames_ground_below_environment),
                   static_cast<long long>(s.frames_mapped));
    }
  }
  return 0;
}
