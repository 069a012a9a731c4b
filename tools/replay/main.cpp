// zonemap-replay: maps a recorded or generated flight and writes DIR/stats.json,
// DIR/boxes.csv, DIR/height.png, DIR/occupied.ply and DIR/run.mcap (usage below).
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include "hal/config/yaml_config.hpp"
#include "hal/os/realtime.hpp"
#include "tools/replay/replay_run.hpp"
#ifdef ZONEMAP_HAVE_STEREO
#include "tools/stereo/asl_stereo.hpp"
#endif

namespace {

constexpr const char* kUsage =
    "usage: zonemap-replay SEQUENCE --config FILE --out DIR [options]\n"
    "  SEQUENCE        a replay directory (FORMATS.md 1: depth.txt, depth/, camera.yaml, poses)\n"
    "                  or an ASL stereo recording (EuRoC MAV: SEQUENCE/mav0/cam0, cam1, ground\n"
    "                  truth), matched on the host into DIR/sequence first (zonemap-stereo)\n"
    "  --config FILE   the mapping configuration (e.g. config/paper-flight2.yaml)\n"
    "  --out DIR       where stats.json, boxes.csv, height.png, occupied.ply and run.mcap go\n"
    "  --camera FILE   camera.yaml to use instead of SEQUENCE/camera.yaml\n"
    "  --quiet         no progress line, no per-frame log\n"
    "  --no-record     no DIR/run.mcap (the Foxglove recording of the run)\n"
    "  --depth-every N every N-th mapped depth frame into run.mcap (default 5; 0: none)\n"
    "  --pipeline      run the onboard runtime (threads and lock-free queues), lossless\n"
    "  --live          the runtime with newest-frame-wins (drops counted)\n"
    "  --rate HZ       pace the frames like a camera at HZ (implies --pipeline)\n"
    "  --mlock         lock the process's memory (needs CAP_IPC_LOCK)\n"
    "  --links DIR     what the vehicle links would carry, stamped with frame times:\n"
    "                  DIR/obstacles.candump (CAN), .lcmlog (LCM), .tlog (MAVLink)\n"
    "  --prior FILE    a prior map (boxes.csv: a saved map, a survey) in the map from the\n"
    "                  first frame, marked prior until a view confirms it\n"
    "  --help          this text\n";

// An ASL stereo recording becomes a section-1 sequence in OUT/sequence first (the
// host does the FPGA's matching); the replay then maps that.
bool stereo_if_asl(zonemap::tools::ReplayOptions* options, const std::string& out_dir,
                   std::vector<std::pair<std::string, std::int64_t>>* figures) {
  const bool asl = std::filesystem::exists(options->sequence_dir + "/mav0/cam0/data.csv");
  if (!asl) return true;
#ifdef ZONEMAP_HAVE_STEREO
  zonemap::stereo::StereoReport report;
  std::string error;
  const std::string converted = out_dir + "/sequence";
  // The matcher's range from the rectified camera and the mapping config's d_min/d_max.
  zonemap::MapConfig config;
  if (!zonemap::hal::load_map_config(options->config_path, &config, &error)) {
    std::fprintf(stderr, "zonemap-replay: %s\n", error.c_str());
    return false;
  }
  zonemap::stereo::StereoOptions stereo_options;
  stereo_options.range_from_camera = true;
  stereo_options.config_d_min_m = config.d_min_m;
  stereo_options.config_d_max_m = config.d_max_m;
  if (!zonemap::stereo::convert_asl(options->sequence_dir, converted, stereo_options, &report,
                                    &error)) {
    std::fprintf(stderr, "zonemap-replay: %s\n", error.c_str());
    return false;
  }
  if (!options->quiet) {
    std::fprintf(stderr,
                 "zonemap-replay: ASL recording: %d pairs matched (SGBM, f %.1f px, b %.4f m, "
                 "%d disparities: %.1f-%.0f m, %.1f%% valid, %.1f ms a pair) -> %s\n",
                 report.written, report.focal_px, report.baseline_m, report.num_disparities,
                 report.min_depth_m, report.max_depth_m, 100 * report.valid_share_median,
                 report.ms_per_pair_median, converted.c_str());
  }
  options->sequence_dir = converted;
  *figures = {{"pairs", report.pairs},
              {"written", report.written},
              {"cam0_without_cam1", report.cam0_without_cam1},
              {"cam1_without_cam0", report.cam1_without_cam0},
              {"unreadable", report.unreadable},
              {"valid_per_mille_median", std::lround(1000 * report.valid_share_median)},
              {"us_per_pair_median", std::lround(1000 * report.ms_per_pair_median)}};
  return true;
#else
  (void)out_dir;
  (void)figures;
  std::fprintf(stderr,
               "zonemap-replay: %s is an ASL stereo recording, and this build has no OpenCV to "
               "match it (install libopencv-calib3d-dev and rebuild, or convert it with "
               "zonemap-stereo where OpenCV is)\n",
               options->sequence_dir.c_str());
  return false;
#endif
}

// The command line: what to map, where to, and how.
struct Arguments {
  zonemap::tools::ReplayOptions options;
  zonemap::runtime::PipelineOptions pipeline;  // flags only: lossless, rate, mlock
  bool pipelined = false;
  bool record = true;
  std::string out_dir;
};

// False (after saying why) when the command line is unusable.
bool parse_arguments(int argc, char** argv, Arguments* a) {
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    auto value = [&](std::string* target) {
      if (i + 1 >= argc) {
        std::fprintf(stderr, "zonemap-replay: %s needs a value\n", arg.c_str());
        return false;
      }
      *target = argv[++i];
      return true;
    };
    bool ok = true;
    if (arg == "--config") {
      ok = value(&a->options.config_path);
    } else if (arg == "--out") {
      ok = value(&a->out_dir);
    } else if (arg == "--camera") {
      ok = value(&a->options.camera_path);
    } else if (arg == "--quiet") {
      a->options.quiet = true;
    } else if (arg == "--no-record") {
      a->record = false;
    } else if (arg == "--depth-every") {
      std::string every;
      ok = value(&every);
      a->options.record_depth_every = std::atoi(every.c_str());
      if (ok && (a->options.record_depth_every < 0 ||
                 every.find_first_not_of("0123456789") != std::string::npos)) {
        std::fprintf(stderr, "zonemap-replay: --depth-every needs a count >= 0\n");
        ok = false;
      }
    } else if (arg == "--pipeline") {
      a->pipelined = true;
    } else if (arg == "--live") {
      a->pipelined = true;
      a->pipeline.lossless = false;
    } else if (arg == "--rate") {
      std::string rate;
      ok = value(&rate);
      a->pipelined = true;
      a->pipeline.source_rate_hz = std::atof(rate.c_str());
      if (!(a->pipeline.source_rate_hz > 0.0)) {
        std::fprintf(stderr, "zonemap-replay: --rate needs a frame rate > 0\n");
        ok = false;
      }
    } else if (arg == "--links") {
      ok = value(&a->options.links_dir);
    } else if (arg == "--prior") {
      ok = value(&a->options.prior_path);
    } else if (arg == "--mlock") {
      a->pipeline.lock_memory = true;
    } else if (!arg.empty() && arg[0] != '-' && a->options.sequence_dir.empty()) {
      a->options.sequence_dir = arg;
    } else {
      std::fprintf(stderr, "zonemap-replay: unknown argument %s\n", arg.c_str());
      ok = false;
    }
    if (!ok) return false;
  }
  if (a->pipelined && !a->options.links_dir.empty()) {
    std::fprintf(stderr,
                 "zonemap-replay: --links needs the single-threaded replay (its files "
                 "are stamped with frame times; the threaded runtime's with the clock)\n");
    return false;
  }
  if (a->options.sequence_dir.empty() || a->options.config_path.empty() || a->out_dir.empty()) {
    std::fputs(kUsage, stderr);
    return false;
  }
  return true;
}

void print_summary(const zonemap::hal::RunStats& s, const Arguments& a) {
  std::printf(
      "frames in %lld, mapped %lld, skipped (no pose) %lld, rejected %lld, dropped %lld; frame ms "
      "p50 %.2f p99 %.2f "
      "max %.2f; zones allocated %lld; reserved %.1f MiB; heap allocations after init %lld\n"
      "outputs: %s/stats.json %s/boxes.csv %s/height.png %s/occupied.ply %s/report.html%s\n",
      static_cast<long long>(s.frames_in), static_cast<long long>(s.frames_mapped),
      static_cast<long long>(s.frames_skipped_no_pose), static_cast<long long>(s.frames_rejected),
      static_cast<long long>(s.frames_dropped()), s.frame_ms_p50, s.frame_ms_p99, s.frame_ms_max,
      static_cast<long long>(s.zones_allocated),
      static_cast<double>(s.static_memory_bytes) / 1048576.0,
      static_cast<long long>(s.heap_allocations_after_init), a.out_dir.c_str(), a.out_dir.c_str(),
      a.out_dir.c_str(), a.out_dir.c_str(), a.out_dir.c_str(),
      a.record ? (" " + a.out_dir + "/run.mcap").c_str() : "");
}

}  // namespace

int main(int argc, char** argv) {
  for (int i = 1; i < argc; ++i) {
    if (std::string(argv[i]) == "--help" || std::string(argv[i]) == "-h") {
      std::fputs(kUsage, stdout);
      return 0;
    }
  }
  if (std::string cpu_problem; !zonemap::os::cpu_runs_this_build(&cpu_problem)) {
    std::fprintf(stderr, "%s: %s\n", argv[0], cpu_problem.c_str());
    return 2;
  }
  Arguments a;
  if (!parse_arguments(argc, argv, &a)) return 2;
  a.options.progress = !a.options.quiet;
  std::vector<std::pair<std::string, std::int64_t>> stereo_figures;
  if (!stereo_if_asl(&a.options, a.out_dir, &stereo_figures)) return 1;
  if (a.record) {
    std::error_code ec;
    std::filesystem::create_directories(a.out_dir, ec);  // the recording starts with the run
    a.options.record_path = a.out_dir + "/run.mcap";
  }
  zonemap::tools::ReplayRun run;
  std::string error;
  if (!run.open(a.options, &error)) {
    std::fprintf(stderr, "zonemap-replay: %s\n", error.c_str());
    return 1;
  }
  run.set_stereo_figures(stereo_figures);
  if (a.pipelined) {
    auto options_from_config = run.pipeline_options();
    options_from_config.lossless = a.pipeline.lossless;
    options_from_config.source_rate_hz = a.pipeline.source_rate_hz;
    options_from_config.lock_memory = options_from_config.lock_memory || a.pipeline.lock_memory;
    run.run_pipelined(options_from_config);
  } else {
    run.run();
  }
  if (!run.write_outputs(a.out_dir, &error)) {
    std::fprintf(stderr, "zonemap-replay: %s\n", error.c_str());
    return 1;
  }
  print_summary(run.stats(), a);
  return 0;
}
