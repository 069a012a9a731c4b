// zonemap-bench: the mapping step measured on generated paper-like frames.
//   zonemap-bench [--frames N]         comparison table: zonemap (projective and
//                                      reference paths) vs OctoMap when built with
//                                      it, per resolution; scaling with image size
//                                      and d_max
//   zonemap-bench --indoor [--frames N]  only the indoor regime (fine cells, d_max 4 m:
//                                      the Kinect frames of ../shared/data, a room)
//   zonemap-bench --micro [gbench args]  Google Benchmark micro benchmarks per stage
//   zonemap-bench --workers [--frames N]  the mapping step with 1, 2 and 4 worker threads
//   zonemap-bench --projective CELL [--frames N] [--repeat R] [--full-extent]
//                                      only the projective path at one cell size, R
//                                      passes, the best median (for profiling: perf
//                                      stat / perf record); --full-extent: 0.25 m
//                                      cells over the 80 x 80 x 40 m environment
// One core, same frames for every contender, frames rendered in memory (no I/O).
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "hal/os/worker_pool.hpp"
#include "hal/replay/sequence.hpp"
#include "tools/sim/scenarios.hpp"
#include "zonemap/features/feature_map.hpp"
#include "zonemap/mapping/mapper.hpp"

#ifdef ZONEMAP_HAVE_OCTOMAP
#include <octomap/octomap.h>
#endif

#include <linux/perf_event.h>
#include <sys/syscall.h>
#include <unistd.h>

namespace {

using namespace zonemap;
using Clock = std::chrono::steady_clock;

struct Frames {
  CameraModel camera;
  std::vector<Eigen::Isometry3d> poses;
  std::vector<std::vector<std::uint16_t>> depth;
  std::vector<std::vector<std::uint8_t>> left;
};

Frames make_frames(int width, int count) {
  sim::Scenario s;
  std::string error;
  sim::make_scenario("treeline", {width, 10.0}, &s, &error);
  Frames f;
  f.camera = s.camera;
  sim::Rng rng(5);
  const std::size_t pixels = static_cast<std::size_t>(s.camera.width) * s.camera.height;
  for (int i = 0; i < count; ++i) {
    // Spread over the approach to the tree line, where the frames see the most.
    const std::size_t k = static_cast<std::size_t>(i) * (s.trajectory.size() * 2 / 3) / count;
    f.poses.push_back(s.trajectory[k].world_T_camera);
    f.depth.emplace_back(pixels);
    f.left.emplace_back(pixels);
    sim::render(s.scene, s.camera, f.poses.back(), sim::RenderOptions{}, rng, f.depth.back().data(),
                f.left.back().data());
  }
  return f;
}

// The environment (one zone's extent, centred on the camera) is 80 x 80 x 40 m at
// 1 and 0.5 m; at 0.25 m it is 64 x 64 x 16 m (256 x 256 x 64 cells, within the
// flight memory budget) unless `full_extent`: then 80 x 80 x 40 m too (320 x 320
// x 160 cells, 33 MB per zone: a benchmark-only configuration).
MapConfig config_for(double cell, double d_max, MapConfig::Integration integration,
                     bool full_extent = false) {
  MapConfig c;
  c.cell_size_m = cell;
  c.zone_cells = cell >= 1.0   ? std::array<int, 3>{80, 80, 40}
                 : cell >= 0.5 ? std::array<int, 3>{160, 160, 80}
                 : full_extent ? std::array<int, 3>{320, 320, 160}
                               : std::array<int, 3>{256, 256, 64};
  c.d_min_m = 8.0;
  c.d_max_m = d_max;
  c.integration = integration;
  return c;
}

// --- the indoor regime: fine cells over a few metres ------------------------------

// config/indoor-kinect.yaml's geometry at `cell`: d 0.5..4 m, no sky, the
// environment 6.4 x 6.4 x 3.2 m at 4 cm; at 2 cm the build maximum of cells per
// zone (256 x 256 x 64: 5.1 x 5.1 x 1.3 m).
MapConfig indoor_config(double cell, MapConfig::Integration integration) {
  MapConfig c;
  c.cell_size_m = cell;
  c.zone_cells = cell >= 0.04 ? std::array<int, 3>{160, 160, 80} : std::array<int, 3>{256, 256, 64};
  c.d_min_m = 0.5;
  c.d_max_m = 4.0;
  c.sky.enabled = false;
  c.integration = integration;
  return c;
}

// The real Kinect v1 frames (7-Scenes redkitchen, ../shared/data) when present.
bool load_kinect_frames(const std::string& dir, int count, Frames* f, std::string* why) {
  replay::ReplaySequence sequence;
  if (!sequence.open(dir, "", indoor_config(0.04, MapConfig::Integration::kProjective), why)) {
    return false;
  }
  f->camera = sequence.camera();
  hal::CameraFrame frame = sequence.make_frame();
  const std::size_t n = sequence.frame_count();
  for (int i = 0; i < count && n > 0; ++i) {
    const std::size_t k = static_cast<std::size_t>(i) * n / static_cast<std::size_t>(count);
    Eigen::Isometry3d pose;
    if (!sequence.read(k, &frame, why) ||
        sequence.poses().lookup(frame.time_s, &pose) == PoseLookup::kNoPose) {
      continue;
    }
    f->poses.push_back(pose);
    f->depth.push_back(frame.depth);
    f->left.emplace_back();  // no left image: DepthFrameView gets none
  }
  return !f->poses.empty();
}

// A generated room (always there): 6 x 5 x 2.6 m with a table, a shelf, a
// cabinet, a lamp and a person, walked through at 1.4 m by a Kinect-like camera
// (640x480, f 585 px) turning as it goes.
Frames make_room_frames(int count) {
  sim::Scene room;
  const auto box = [&](double x0, double y0, double z0, double x1, double y1, double z1) {
    room.boxes.push_back({"", {x0, y0, z0}, {x1, y1, z1}});
  };
  box(-3.0, -2.5, 0.0, 3.0, -2.4, 2.6);  // walls
  box(-3.0, 2.4, 0.0, 3.0, 2.5, 2.6);
  box(-3.0, -2.5, 0.0, -2.9, 2.5, 2.6);
  box(2.9, -2.5, 0.0, 3.0, 2.5, 2.6);
  box(-3.0, -2.5, 2.6, 3.0, 2.5, 2.7);   // ceiling
  box(0.5, -0.5, 0.72, 1.7, 0.4, 0.76);  // table top and legs
  for (const double x : {0.55, 1.62})
    for (const double y : {-0.45, 0.32}) box(x, y, 0.0, x + 0.05, y + 0.05, 0.72);
  box(-2.8, -1.5, 0.0, -2.4, 0.5, 1.9);                          // shelf
  box(1.8, 1.6, 0.0, 2.8, 2.3, 0.9);                             // cabinet
  room.cylinders.push_back({"", {-1.5, 1.5}, 0.12, 0.0, 1.6});   // lamp
  room.cylinders.push_back({"", {1.0, -1.6}, 0.25, 0.0, 1.75});  // person
  Frames f;
  f.camera.width = 640;
  f.camera.height = 480;
  f.camera.fx = f.camera.fy = 585.0;
  f.camera.cx = 320.0;
  f.camera.cy = 240.0;
  f.camera.baseline_m = 0.075;
  f.camera.match_sigma_px = 0.5;
  f.camera.depth_scale = 1000.0;
  sim::RenderOptions options;
  options.max_range_m = 8.0;
  options.noise_sigma_px = 0.25;
  sim::Rng rng(11);
  const std::size_t pixels = static_cast<std::size_t>(f.camera.width) * f.camera.height;
  for (int i = 0; i < count; ++i) {
    const double t = static_cast<double>(i) / static_cast<double>(std::max(1, count - 1));
    const Eigen::Vector3d at(-1.6 + 2.6 * t, -0.9 + 1.4 * std::sin(3.0 * t), 1.4);
    f.poses.push_back(sim::look_pose(at, 0.4 + 2.4 * t, 0.3));
    f.depth.emplace_back(pixels);
    f.left.emplace_back(pixels);
    sim::render(room, f.camera, f.poses.back(), options, rng, f.depth.back().data(),
                f.left.back().data());
  }
  return f;
}

// Instructions retired in user space by this thread, from the kernel's
// performance counters: a per-frame cost that, unlike milliseconds, does not move
// with the machine's load or clock. Unavailable (a VM without counters,
// perf_event_paranoid > 2): valid() is false and the tables print "-".
class InstructionCounter {
 public:
  InstructionCounter() {
    perf_event_attr attr{};
    attr.type = PERF_TYPE_HARDWARE;
    attr.size = sizeof(attr);
    attr.config = PERF_COUNT_HW_INSTRUCTIONS;
    attr.exclude_kernel = 1;
    attr.exclude_hv = 1;
    fd_ = static_cast<int>(syscall(SYS_perf_event_open, &attr, 0, -1, -1, 0));
    if (fd_ < 0) error_ = errno;
  }
  ~InstructionCounter() {
    if (fd_ >= 0) close(fd_);
  }
  InstructionCounter(const InstructionCounter&) = delete;
  InstructionCounter& operator=(const InstructionCounter&) = delete;
  bool valid() const { return fd_ >= 0; }
  // Why there is no counter (errno of perf_event_open), 0 when there is one.
  int error() const { return error_; }
  // The running count (0 when unavailable).
  std::uint64_t read_count() const {
    std::uint64_t count = 0;
    if (fd_ < 0 || read(fd_, &count, sizeof(count)) != static_cast<ssize_t>(sizeof(count)))
      return 0;
    return count;
  }

 private:
  int fd_ = -1;
  int error_ = 0;
};

// One counter for the whole run (opened at first use).
const InstructionCounter& instruction_counter() {
  static const InstructionCounter counter;
  return counter;
}

struct Timing {
  double median_ms = 0, p99_ms = 0;
  double median_minstr = -1;  // million instructions, the median frame; < 0: no counter
  double cells_per_frame = 0;
  double block_free_per_frame = 0;   // projective: settled by the block or box bound
  double hidden_per_frame = 0;       // projective: behind every surface
  double by_block_per_frame = 0;     // projective: of block_free_per_frame, by the block's bound
  double exact_cells_per_frame = 0;  // projective: settled ray by ray
  double exact_rays_per_frame = 0;
};

Timing summarise(std::vector<double> ms, double cells) {
  std::sort(ms.begin(), ms.end());
  Timing t;
  t.median_ms = ms[ms.size() / 2];
  t.p99_ms =
      ms[std::min(ms.size() - 1, static_cast<std::size_t>(0.99 * static_cast<double>(ms.size())))];
  t.cells_per_frame = cells;
  return t;
}

Timing time_zonemap(const Frames& f, const MapConfig& config, WorkSplit* split = nullptr) {
  Mapper mapper(config, f.camera);
  mapper.set_work_split(split);
  const InstructionCounter& counter = instruction_counter();
  std::vector<double> ms, minstr;
  double cells = 0, block_free = 0, by_block = 0, hidden = 0, exact_cells = 0, exact_rays = 0;
  for (std::size_t i = 0; i < f.poses.size(); ++i) {
    DepthFrameView view{f.depth[i].data(), f.left[i].data(), f.camera.width, f.camera.height};
    const std::uint64_t i0 = counter.read_count();
    const auto t0 = Clock::now();
    const FrameReport r = mapper.integrate(view, f.poses[i]);
    ms.push_back(std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
    minstr.push_back(static_cast<double>(counter.read_count() - i0) * 1e-6);
    cells += static_cast<double>(r.cells_visited);
    block_free += static_cast<double>(r.cells_block_free + r.cells_box_free);
    by_block += static_cast<double>(r.cells_block_free);
    hidden += static_cast<double>(r.cells_hidden);
    exact_cells += static_cast<double>(r.cells_exact);
    exact_rays += static_cast<double>(r.rays_exact);
  }
  const double n = static_cast<double>(f.poses.size());
  Timing t = summarise(ms, cells / n);
  if (counter.valid()) {
    std::sort(minstr.begin(), minstr.end());
    t.median_minstr = minstr[minstr.size() / 2];
  }
  t.block_free_per_frame = block_free / n;
  t.hidden_per_frame = hidden / n;
  t.by_block_per_frame = by_block / n;
  t.exact_cells_per_frame = exact_cells / n;
  t.exact_rays_per_frame = exact_rays / n;
  return t;
}

// The fast path against the reference on the same frames, M̂ as drawn (no blur),
// counted as in the Projective.* tests: cells either touches, same sign,
// occupied in the reference and missed, free where the reference has nothing —
// the last two beyond the one Q6 step by which the paths may round apart (those
// ties counted on their own).
struct Agreement {
  long long touched = 0, same_sign = 0, occupied = 0, occupied_missed = 0, free_without_ray = 0;
  long long rounding_ties = 0;
};

Agreement agreement(const Frames& f, MapConfig config) {
  config.integration = MapConfig::Integration::kReference;
  config.blur_radius = 0;
  Mapper reference(config, f.camera);
  config.integration = MapConfig::Integration::kProjective;
  Mapper fast(config, f.camera);
  Agreement a;
  for (std::size_t i = 0; i < f.poses.size(); ++i) {
    DepthFrameView view{f.depth[i].data(), f.left[i].data(), f.camera.width, f.camera.height};
    reference.integrate(view, f.poses[i]);
    fast.integrate(view, f.poses[i]);
    const LocalGrid& r = reference.local_grid();
    const LocalGrid& p = fast.local_grid();
    for (std::size_t k = 0; k < r.cell_count(); ++k) {
      const int rv = r.data()[k] == kUntouched ? 0 : r.data()[k];
      const int fv = p.data()[k] == kUntouched ? 0 : p.data()[k];
      if (rv == 0 && fv == 0) continue;
      ++a.touched;
      if ((rv > 0) == (fv > 0) && (rv < 0) == (fv < 0)) ++a.same_sign;
      if (rv > 0) ++a.occupied;
      const bool missed = rv > 0 && fv <= 0;
      const bool free_without_ray = rv == 0 && fv < 0;
      if ((missed || free_without_ray) && rv - fv <= 1) {
        ++a.rounding_ties;
      } else {
        if (missed) ++a.occupied_missed;
        if (free_without_ray) ++a.free_without_ray;
      }
    }
  }
  return a;
}

#ifdef ZONEMAP_HAVE_OCTOMAP
Timing time_octomap(const Frames& f, double cell, double d_min, double d_max, std::size_t frames) {
  octomap::OcTree tree(cell);
  std::vector<double> ms;
  for (std::size_t i = 0; i < std::min(frames, f.poses.size()); ++i) {
    octomap::Pointcloud cloud;
    const auto& k = f.camera;
    for (int v = 0; v < k.height; ++v)
      for (int u = 0; u < k.width; ++u) {
        const std::uint16_t raw = f.depth[i][static_cast<std::size_t>(v) * k.width + u];
        if (raw == 0) continue;
        const double d = raw / k.depth_scale;
        if (d < d_min) continue;
        const Eigen::Vector3d p =
            f.poses[i] * Eigen::Vector3d(d * (u - k.cx) / k.fx, d * (v - k.cy) / k.fy, d);
        cloud.push_back(static_cast<float>(p.x()), static_cast<float>(p.y()),
                        static_cast<float>(p.z()));
      }
    const Eigen::Vector3d o = f.poses[i].translation();
    const auto t0 = Clock::now();
    // Its fastest settings: discretised end points, lazy inner-node updates.
    tree.insertPointCloud(cloud,
                          octomap::point3d(static_cast<float>(o.x()), static_cast<float>(o.y()),
                                           static_cast<float>(o.z())),
                          d_max, true, true);
    ms.push_back(std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
  }
  return summarise(ms, 0);
}
#endif

std::string minstr_text(const Timing& t) {
  if (t.median_minstr < 0.0) return "-";
  char text[32];
  std::snprintf(text, sizeof(text), "%.1f", t.median_minstr);
  return text;
}

// One indoor row: the projective path (and the reference at 4 cm) against OctoMap
// on the same frames, then the agreement with the reference.
void indoor_row(const char* name, const Frames& f, double cell) {
  const Timing fast = time_zonemap(f, indoor_config(cell, MapConfig::Integration::kProjective));
  char ref_text[64] = "-";
  if (cell >= 0.04) {
    const Timing ref = time_zonemap(f, indoor_config(cell, MapConfig::Integration::kReference));
    std::snprintf(ref_text, sizeof(ref_text), "%.1f / %.1f", ref.median_ms, ref.p99_ms);
  }
  char octo_text[64] = "not built";
  char ratio_text[32] = "-";
#ifdef ZONEMAP_HAVE_OCTOMAP
  const Timing octo = time_octomap(f, cell, 0.5, 4.0, f.poses.size());
  std::snprintf(octo_text, sizeof(octo_text), "%.1f / %.1f", octo.median_ms, octo.p99_ms);
  std::snprintf(ratio_text, sizeof(ratio_text), "%.2fx", octo.median_ms / fast.median_ms);
#endif
  char fast_text[64];
  std::snprintf(fast_text, sizeof(fast_text), "%.1f / %.1f", fast.median_ms, fast.p99_ms);
  std::printf("%-18s %-5.2f %-18s %-18s %-18s %-8s %-12.0f %-8s %.0f / %.0f / %.0f\n", name, cell,
              fast_text, ref_text, octo_text, ratio_text, fast.cells_per_frame,
              minstr_text(fast).c_str(), fast.block_free_per_frame, fast.exact_cells_per_frame,
              fast.exact_rays_per_frame);
}

void indoor_agreement(const char* name, const Frames& f, double cell) {
  const Agreement a = agreement(f, indoor_config(cell, MapConfig::Integration::kReference));
  std::printf(
      "%s %.2f m: same sign on %.3f%% of %lld cells either touches; occupied in the reference "
      "%lld, missed %lld; free where the reference has no ray %lld; a rounding step apart %lld\n",
      name, cell, 100.0 * static_cast<double>(a.same_sign) / static_cast<double>(a.touched),
      a.touched, a.occupied, a.occupied_missed, a.free_without_ray, a.rounding_ties);
}

// Fine cells over a few metres (handheld, indoor, close-range flight): the real
// Kinect frames when ../shared/data has them, and a generated room always.
void indoor_comparison(int frame_count) {
  std::printf(
      "\nindoor: 640x480, d 0.5-4 m, no sky; environment 6.4 x 6.4 x 3.2 m at 4 cm, 5.1 x 5.1 x "
      "1.3 m at 2 cm; %d frames\n",
      frame_count);
  std::printf("%-18s %-5s %-18s %-18s %-18s %-8s %-12s %-8s %s\n", "frames", "cell",
              "projective ms", "reference ms", "octomap 1.9.7 ms", "ratio", "cells/frame",
              "M instr", "quick-free / exact cells / rays");
  std::vector<std::pair<const char*, Frames>> sets;
  Frames kinect;
  std::string why;
  if (load_kinect_frames(std::string(ZONEMAP_SHARED_DATA_DIR) + "/redkitchen-0000-0059",
                         frame_count, &kinect, &why)) {
    sets.emplace_back("kinect redkitchen", std::move(kinect));
  } else {
    std::printf("(no Kinect frames: %s)\n", why.c_str());
  }
  sets.emplace_back("generated room", make_room_frames(frame_count));
  for (const auto& [name, frames] : sets) {
    for (const double cell : {0.04, 0.02}) indoor_row(name, frames, cell);
  }
  std::printf("ratio: OctoMap's median over the projective path's (above 1: zonemap faster)\n");
  for (const auto& [name, frames] : sets) indoor_agreement(name, frames, 0.04);
}

// The parts of each job run one after another on this thread, each timed: a
// frame's time with `parts` workers of their own is then its time here minus,
// per job, every part but the longest (what the split would run at once).
class TimedSerialSplit final : public WorkSplit {
 public:
  explicit TimedSerialSplit(int parts) : parts_(parts) {}
  int parts() const override { return parts_; }
  void run(Job job, void* context) override {
    double sum = 0, longest = 0;
    for (int p = 0; p < parts_; ++p) {
      const auto t0 = Clock::now();
      job(context, p, parts_);
      const double ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
      sum += ms;
      longest = std::max(longest, ms);
    }
    saved_ms += sum - longest;
  }
  double saved_ms = 0;  // since the last reset

 private:
  int parts_;
};

// The mapping step's median with the work split `parts` ways: as simulated
// (TimedSerialSplit) and as run on this machine's cores (hal/os/worker_pool).
double simulated_median_ms(const Frames& f, const MapConfig& config, int parts) {
  Mapper mapper(config, f.camera);
  TimedSerialSplit split(parts);
  mapper.set_work_split(&split);
  std::vector<double> ms;
  for (std::size_t i = 0; i < f.poses.size(); ++i) {
    const DepthFrameView view{f.depth[i].data(), f.left[i].data(), f.camera.width, f.camera.height};
    split.saved_ms = 0;
    const auto t0 = Clock::now();
    mapper.integrate(view, f.poses[i]);
    ms.push_back(std::chrono::duration<double, std::milli>(Clock::now() - t0).count() -
                 split.saved_ms);
  }
  return summarise(ms, 0).median_ms;
}

// The shared parts (depth classification, range table, block classes, frustum
// walk, blur, zone clearing, fusion) among worker threads, the rest on the
// mapping thread; the map is the same for any count (WorkerPool.*).
void workers_comparison(const Frames& f) {
  const unsigned cores = std::thread::hardware_concurrency();
  std::printf(
      "\nmapping workers (projective 0.5 m, tree line; depth classification, range table, block\n"
      "classes, frustum walk, blur, zone clearing and fusion shared; range weighting and the\n"
      "zone bookkeeping on the mapping thread): ms median, the least of three passes;\n"
      "simulated = the parts run one after another and timed, a frame counted as if they ran\n"
      "at once; threads = on this machine's %u cores\n",
      cores);
  std::printf("%-8s %-22s %-22s\n", "workers", "simulated (speed-up)", "threads (speed-up)");
  const MapConfig config = config_for(0.5, 50.0, MapConfig::Integration::kProjective);
  // Each figure the least disturbed of three passes (the machine is shared).
  const auto best_of_three = [](auto&& median_ms) {
    return std::min({median_ms(), median_ms(), median_ms()});
  };
  const double one = best_of_three([&] { return time_zonemap(f, config).median_ms; });
  std::printf("%-8d %-22s %.2f\n", 1, "-", one);
  for (int parts : {2, 4}) {
    const double simulated = best_of_three([&] { return simulated_median_ms(f, config, parts); });
    char threads[64] = "-";
    if (static_cast<unsigned>(parts) <= cores) {
      os::WorkerPool pool(os::WorkerOptions{parts, 0, {}});
      const double ms = best_of_three([&] { return time_zonemap(f, config, &pool).median_ms; });
      std::snprintf(threads, sizeof threads, "%.2f (%.2fx)", ms, one / ms);
    }
    char sim[64];
    std::snprintf(sim, sizeof sim, "%.2f (%.2fx)", simulated, one / simulated);
    std::printf("%-8d %-22s %s\n", parts, sim, threads);
  }
}

void comparison(int frame_count) {
  std::printf(
      "zonemap-bench: mapping step per frame (sensor model, local grid, blur, fusion), one core,\n"
      "generated tree-line flight, d_max 50 m, %d frames; ms median / p99; M instr: million\n"
      "instructions of the median frame (user space; steady when milliseconds are not)\n\n",
      frame_count);
  if (!instruction_counter().valid()) {
    // Say why the column is empty, and how to count without hardware counters.
    std::printf(
        "M instr \"-\": no hardware instruction counter (perf_event_open: %s; a VM\n"
        "without a PMU says so, perf_event_paranoid > 2 gives a permission error): tools/bench\n"
        "then counts them with valgrind, --tool=callgrind --toggle-collect='zonemap::Mapper::\n"
        "integrate(*' build/release/zonemap-bench --projective 0.5 --frames 12, Ir / 12 (this\n"
        "includes the first frame's clearing of its new zones: ~4 M a frame at 0.5 m)\n\n",
        std::strerror(instruction_counter().error()));
  }
  const Frames f640 = make_frames(640, frame_count);
  std::printf("%-6s %-22s %-22s %-22s %-10s %-12s %-9s %-8s %-18s\n", "cell", "zonemap projective",
              "zonemap reference", "octomap 1.9.7", "ratio", "cells/frame", "ns/cell", "M instr",
              "quick-free / exact cells / rays");
  for (const double cell : {1.0, 0.5, 0.25, -0.25}) {  // -0.25: 0.25 m, 80 x 80 x 40 m
    const bool full_extent = cell < 0.0;
    const Timing fast = time_zonemap(
        f640, config_for(std::fabs(cell), 50.0, MapConfig::Integration::kProjective, full_extent));
    Timing reference;
    if (cell >= 0.5)
      reference = time_zonemap(f640, config_for(cell, 50.0, MapConfig::Integration::kReference));
    char ref_text[64] = "-";
    if (cell >= 0.5)
      std::snprintf(ref_text, sizeof(ref_text), "%.1f / %.1f", reference.median_ms,
                    reference.p99_ms);
    char octo_text[64] = "not built";
    char ratio_text[32] = "-";
#ifdef ZONEMAP_HAVE_OCTOMAP
    // OctoMap has no environment: one figure per resolution, the full range.
    static Timing octo;
    if (!full_extent)
      octo = time_octomap(f640, cell, 8.0, 50.0,
                          cell < 0.5 ? 3 : static_cast<std::size_t>(frame_count));
    std::snprintf(octo_text, sizeof(octo_text), "%.1f / %.1f", octo.median_ms, octo.p99_ms);
    std::snprintf(ratio_text, sizeof(ratio_text), "%.1fx", octo.median_ms / fast.median_ms);
#endif
    char fast_text[64];
    std::snprintf(fast_text, sizeof(fast_text), "%.1f / %.1f", fast.median_ms, fast.p99_ms);
    std::printf("%-6s %-22s %-22s %-22s %-10s %-12.0f %-9.1f %-8s %.0f / %.0f / %.0f\n",
                full_extent ? "0.25*" : (std::to_string(cell).substr(0, 4)).c_str(), fast_text,
                ref_text, octo_text, ratio_text, fast.cells_per_frame,
                fast.median_ms * 1e6 / std::max(1.0, fast.cells_per_frame),
                minstr_text(fast).c_str(), fast.block_free_per_frame, fast.exact_cells_per_frame,
                fast.exact_rays_per_frame);
  }
  std::printf(
      "0.25: 64 x 64 x 16 m environment (flight budget); 0.25*: 80 x 80 x 40 m, as at 1 and "
      "0.5 m\n");
  std::printf("\nagreement of the projective path with the reference, same frames, as drawn:\n");
  for (const double cell : {1.0, 0.5}) {
    const Agreement a = agreement(f640, config_for(cell, 50.0, MapConfig::Integration::kReference));
    std::printf(
        "%.2f m: same sign on %.3f%% of %lld cells either touches; occupied in the reference "
        "%lld, missed %lld; free where the reference has no ray %lld; a rounding step apart %lld\n",
        cell, 100.0 * static_cast<double>(a.same_sign) / static_cast<double>(a.touched), a.touched,
        a.occupied, a.occupied_missed, a.free_without_ray, a.rounding_ties);
  }
  workers_comparison(f640);
  indoor_comparison(frame_count);
  std::printf(
      "\nscaling (projective, 0.5 m cells): image size at d_max 50 m, then d_max at 640x480\n");
  std::printf("%-18s %-16s %-14s %-8s\n", "case", "ms median / p99", "cells/frame", "M instr");
  for (int width : {320, 640, 1280}) {
    const Frames f = width == 640 ? f640 : make_frames(width, std::max(4, frame_count / 2));
    const Timing t = time_zonemap(f, config_for(0.5, 50.0, MapConfig::Integration::kProjective));
    char text[64];
    std::snprintf(text, sizeof(text), "%.1f / %.1f", t.median_ms, t.p99_ms);
    std::printf("%-18s %-16s %-14.0f %-8s\n",
                (std::to_string(width) + "x" + std::to_string(width * 3 / 4)).c_str(), text,
                t.cells_per_frame, minstr_text(t).c_str());
  }
  for (double d_max : {25.0, 50.0, 100.0}) {
    const Timing t =
        time_zonemap(f640, config_for(0.5, d_max, MapConfig::Integration::kProjective));
    char text[64];
    std::snprintf(text, sizeof(text), "%.1f / %.1f", t.median_ms, t.p99_ms);
    std::printf("%-18s %-16s %-14.0f %-8s\n",
                ("d_max " + std::to_string(static_cast<int>(d_max)) + " m").c_str(), text,
                t.cells_per_frame, minstr_text(t).c_str());
  }
}

// --- micro benchmarks -------------------------------------------------------------

const Frames& micro_frames() {
  static const Frames f = make_frames(640, 4);
  return f;
}

void BM_SensorModel(benchmark::State& state) {
  float delta = 8.0f, sum = 0.0f;
  for (auto _ : state) {
    sum += sensor_model_value(delta, 30.0f, 1.1f);
    delta = delta > 50.0f ? 8.0f : delta + 0.37f;
    benchmark::DoNotOptimize(sum);
  }
}
BENCHMARK(BM_SensorModel);

void BM_MappingStep(benchmark::State& state) {
  const Frames& f = micro_frames();
  const auto integration = state.range(0) == 0 ? MapConfig::Integration::kProjective
                                               : MapConfig::Integration::kReference;
  Mapper mapper(config_for(0.5, 50.0, integration), f.camera);
  std::size_t i = 0;
  for (auto _ : state) {
    DepthFrameView view{f.depth[i].data(), f.left[i].data(), f.camera.width, f.camera.height};
    benchmark::DoNotOptimize(mapper.integrate(view, f.poses[i]));
    i = (i + 1) % f.poses.size();
  }
}
BENCHMARK(BM_MappingStep)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

void BM_DepthRangeTableBuild(benchmark::State& state) {
  const Frames& f = micro_frames();
  DepthRangeTable table(f.camera.width, f.camera.height);
  for (auto _ : state) {
    std::copy(f.depth[0].begin(), f.depth[0].end(), table.base());
    table.build();
    benchmark::ClobberMemory();
  }
}
BENCHMARK(BM_DepthRangeTableBuild)->Unit(benchmark::kMicrosecond);

// The worst case: every cell of a 121 x 121 x 61 region holds a value (a frame
// leaves most rows of its box 0, which the blur passes over).
void BM_BlurTouchedRegion(benchmark::State& state) {
  LocalGrid grid({160, 160, 80});
  for (auto _ : state) {
    state.PauseTiming();
    grid.reset({0, 0, 0});
    grid.extend_touched(20, 20, 10, 140, 140, 70);
    for (int z = 10; z <= 70; ++z)
      for (int y = 20; y <= 140; ++y)
        for (int x = 20; x <= 140; ++x)
          grid.write_max(x, y, z, static_cast<LocalCell>((x + 3 * y + 7 * z) % 129 - 64));
    state.ResumeTiming();
    grid.finish(1);
  }
}
BENCHMARK(BM_BlurTouchedRegion)->Unit(benchmark::kMillisecond);

// A flight-2 mapper with the micro frames integrated: its live zones hold a map.
std::unique_ptr<Mapper> mapped_flight2(MapConfig* config) {
  const Frames& f = micro_frames();
  *config = config_for(0.5, 50.0, MapConfig::Integration::kProjective);
  auto mapper = std::make_unique<Mapper>(*config, f.camera);
  for (std::size_t i = 0; i < f.poses.size(); ++i) {
    mapper->integrate({f.depth[i].data(), f.left[i].data(), f.camera.width, f.camera.height},
                      f.poses[i]);
  }
  return mapper;
}

void BM_FeatureExtractionZone(benchmark::State& state) {
  MapConfig config;
  const std::unique_ptr<Mapper> mapper = mapped_flight2(&config);
  FeatureMap features(config, true);
  for (auto _ : state) {
    mapper->zones().for_each_live_zone([&](ZoneView& zone) { features.extract(zone); });
  }
  state.counters["zones"] = mapper->zones().live_zone_count();
}
BENCHMARK(BM_FeatureExtractionZone)->Unit(benchmark::kMillisecond);

void BM_ZoneSnapshotCapture(benchmark::State& state) {
  MapConfig config;
  const std::unique_ptr<Mapper> mapper = mapped_flight2(&config);
  ZoneSnapshot snapshot(config.zone_cells, coarse_level_step(config));
  for (auto _ : state) {
    mapper->zones().for_each_live_zone([&](ZoneView& zone) { snapshot.capture(zone, 96); });
    benchmark::ClobberMemory();
  }
  state.counters["zones"] = mapper->zones().live_zone_count();
}
BENCHMARK(BM_ZoneSnapshotCapture)->Unit(benchmark::kMillisecond);

}  // namespace

int main(int argc, char** argv) {
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--help") == 0 || std::strcmp(argv[i], "-h") == 0) {
      std::fputs(
          "usage: zonemap-bench [--frames N] [--full-extent] [--indoor] [--workers] [--projective "
          "CELL_M "
          "[--repeat N]]\n"
          "       zonemap-bench --micro [Google Benchmark flags]\n"
          "  (no option)          the table: projective and reference paths against OctoMap when\n"
          "                       built with it, per cell size, agreement, scaling, replays\n"
          "  --frames N           frames per case (default 12)\n"
          "  --full-extent        0.25 m over the whole 80 x 80 x 40 m environment too\n"
          "  --indoor             only the indoor regime (Kinect frames, generated room)\n"
          "  --room               with --indoor --projective: the generated room even when the\n"
          "                       Kinect frames are there\n"
          "  --workers            only the mapping step with 1, 2 and 4 worker threads\n"
          "  --projective CELL_M  only the projective path at one cell size (for perf/callgrind);\n"
          "                       with --indoor, on the Kinect frames (or the generated room)\n"
          "  --repeat N           passes over the same frames with --projective\n"
          "  --micro              the per-stage micro benchmarks\n",
          stdout);
      return 0;
    }
  }
  if (argc > 1 && std::strcmp(argv[1], "--micro") == 0) {
    argv[1] = argv[0];
    int n = argc - 1;
    benchmark::Initialize(&n, argv + 1);
    benchmark::RunSpecifiedBenchmarks();
    return 0;
  }
  int frames = 12;
  int repeat = 1;
  bool full_extent = false;
  bool indoor_only = false;
  bool workers_only = false;
  bool room = false;
  double only_cell = 0.0;
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--full-extent") == 0) full_extent = true;
    if (std::strcmp(argv[i], "--indoor") == 0) indoor_only = true;
    if (std::strcmp(argv[i], "--workers") == 0) workers_only = true;
    if (std::strcmp(argv[i], "--room") == 0) room = true;
    if (i + 1 >= argc) continue;
    if (std::strcmp(argv[i], "--frames") == 0) frames = std::max(2, std::atoi(argv[i + 1]));
    if (std::strcmp(argv[i], "--projective") == 0) only_cell = std::atof(argv[i + 1]);
    if (std::strcmp(argv[i], "--repeat") == 0) repeat = std::max(1, std::atoi(argv[i + 1]));
  }
  if (workers_only) {
    workers_comparison(make_frames(640, frames));
    return 0;
  }
  if (only_cell > 0.0 && indoor_only) {
    // The Kinect frames (or the generated room without them) at one cell size,
    // for perf/callgrind.
    Frames f;
    std::string why;
    const bool kinect =
        !room && load_kinect_frames(std::string(ZONEMAP_SHARED_DATA_DIR) + "/redkitchen-0000-0059",
                                    frames, &f, &why);
    if (!kinect) f = make_room_frames(frames);
    const Timing t = time_zonemap(f, indoor_config(only_cell, MapConfig::Integration::kProjective));
    std::printf(
        "indoor projective %.2f m (%s): %.2f ms median, %.2f ms p99, %s M instructions median; "
        "per frame %.0f cells evaluated (%.0f free by a bound, %.0f of them by their block's), "
        "%.0f hidden, %.0f settled ray by ray (%.0f rays)\n",
        only_cell, kinect ? "kinect redkitchen" : "generated room", t.median_ms, t.p99_ms,
        minstr_text(t).c_str(), t.cells_per_frame, t.block_free_per_frame, t.by_block_per_frame,
        t.hidden_per_frame, t.exact_cells_per_frame, t.exact_rays_per_frame);
    return 0;
  }
  if (only_cell > 0.0) {
    const Frames f = make_frames(640, frames);
    // Repeated passes over the same frames: the smallest median is the least
    // disturbed one (and perf stat differences between repeat counts give the
    // instructions per frame without the rendering).
    Timing t;
    for (int pass = 0; pass < repeat; ++pass) {
      const Timing run = time_zonemap(
          f, config_for(only_cell, 50.0, MapConfig::Integration::kProjective, full_extent));
      if (pass == 0 || run.median_ms < t.median_ms) t = run;
    }
    std::printf(
        "projective %.2f m: %.2f ms median, %.2f ms p99, %s M instructions median; per frame %.0f "
        "cells evaluated (%.0f free by a bound), %.0f hidden, %.0f settled ray by ray (%.0f "
        "rays)\n",
        only_cell, t.median_ms, t.p99_ms, minstr_text(t).c_str(), t.cells_per_frame,
        t.block_free_per_frame, t.hidden_per_frame, t.exact_cells_per_frame,
        t.exact_rays_per_frame);
    return 0;
  }
  if (indoor_only) {
    indoor_comparison(frames);
    return 0;
  }
  comparison(frames);
  return 0;
}
