// zonemap-soak: the generated out-and-back flight looped through the threaded
// pipeline (live INS thread, newest-wins camera at the given rate) for as many
// frames as asked; soak.json with memory and counters sampled every 10 s.
//   zonemap-soak [--frames 54000] [--rate 30] [--width 640] [--pixel-step 1] [--out DIR]
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include "hal/os/realtime.hpp"
#include "tools/soak/soak.hpp"

int main(int argc, char** argv) {
  if (std::string cpu_problem; !zonemap::os::cpu_runs_this_build(&cpu_problem)) {
    std::fprintf(stderr, "%s: %s\n", argv[0], cpu_problem.c_str());
    return 2;
  }
  zonemap::soak::SoakOptions options;
  std::string out = "out/soak";
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (i + 1 >= argc) {
      std::fprintf(stderr,
                   "usage: zonemap-soak [--frames N] [--rate HZ] [--width W] "
                   "[--pixel-step S] [--loop-frames N] [--out DIR]\n");
      return 2;
    }
    const std::string value = argv[++i];
    if (arg == "--frames")
      options.frames = std::atoll(value.c_str());
    else if (arg == "--rate")
      options.rate_hz = std::atof(value.c_str());
    else if (arg == "--width")
      options.width = std::atoi(value.c_str());
    else if (arg == "--pixel-step")
      options.pixel_step = std::atoi(value.c_str());
    else if (arg == "--loop-frames")
      options.max_loop_frames = std::atoll(value.c_str());
    else if (arg == "--out")
      out = value;
    else {
      std::fprintf(stderr, "zonemap-soak: unknown option %s\n", arg.c_str());
      return 2;
    }
  }
  zonemap::soak::SoakResult result;
  std::string error;
  if (!zonemap::soak::run_soak(options, &result, &error)) {
    std::fprintf(stderr, "zonemap-soak: %s\n", error.c_str());
    return 1;
  }
  std::filesystem::create_directories(out);
  std::ofstream(out + "/soak.json") << zonemap::soak::to_json(options, result);
  const auto& s = result.stats;
  std::printf(
      "zonemap-soak: %lld frames in, %lld mapped, %lld dropped; RSS %ld -> %ld bytes; "
      "allocations after init %lld; features %lld of %zu; e2e p99 %.1f ms; %s/soak.json\n",
      static_cast<long long>(s.frames_in), static_cast<long long>(s.frames_mapped),
      static_cast<long long>(s.dropped_mapper_behind + s.dropped_pool_full), s.rss_after_start,
      s.rss_at_end,
      static_cast<long long>(s.mapping_thread_allocations + s.output_thread_allocations +
                             s.ins_thread_allocations + s.extraction_thread_allocations),
      static_cast<long long>(result.features_at_end), result.features_capacity,
      s.end_to_end.percentile(0.99), out.c_str());
  return 0;
}
