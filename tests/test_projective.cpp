// The fast (projective) integration path against the reference ray traversal:
// same sign on >= 99.9% of the cells either touches (the issue asks 99%), no
// occupied reference cell missed, no free value where no ray crosses, values
// never below the reference's, on generated and real frames. Both paths round
// m̂ to Q6 in float: where m̂ lies on a step's edge (±1/128) they may round
// apart by one step, which is all these checks allow (a reference +1/64 that
// the fast path has at 0, a reference 0 that it has at -1/64).
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <functional>
#include <tuple>

#include "hal/config/yaml_config.hpp"
#include "hal/os/allocation_counter.hpp"
#include "hal/replay/sequence.hpp"
#include "test_support.hpp"
#include "zonemap/mapping/mapper.hpp"

namespace zonemap {
namespace {

struct Agreement {
  std::int64_t touched = 0;  // non-zero in either grid
  std::int64_t same_sign = 0;
  std::int64_t occupied_reference = 0;
  std::int64_t occupied_missed = 0;  // occupied in the reference, not in the fast grid
                                     // (beyond rounding apart by one step)
  std::int64_t free_where_none = 0;  // free in the fast grid beyond that step, 0 in the reference
  std::int64_t below_reference = 0;  // touched by both, fast value below the reference's
  int largest_shortfall = 0;         // by how much at most (1/64 units)
  std::int64_t above_reference_sum = 0;  // the sum of what the fast values exceed it by (1/64)
  std::int64_t above_reference = 0;      // fast above by more than a rounding step
  std::int64_t kinds[3][3] = {};         // [reference sign + 1][fast sign + 1]

  void add(const Agreement& a) {
    touched += a.touched;
    same_sign += a.same_sign;
    occupied_reference += a.occupied_reference;
    occupied_missed += a.occupied_missed;
    free_where_none += a.free_where_none;
    below_reference += a.below_reference;
    above_reference_sum += a.above_reference_sum;
    above_reference += a.above_reference;
    largest_shortfall = std::max(largest_shortfall, a.largest_shortfall);
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) kinds[r][c] += a.kinds[r][c];
  }
};

// Cells whose centre (world frame) it accepts; none: every cell.
using CellRegion = std::function<bool(const Eigen::Vector3d&)>;

Agreement compare_frame(const MapConfig& base_config, const CameraModel& camera,
                        const DepthFrameView& frame, const Eigen::Isometry3d& pose,
                        const CellRegion& region = nullptr) {
  MapConfig config = base_config;
  config.blur_radius = 0;  // compare M̂ as drawn
  config.integration = MapConfig::Integration::kReference;
  Mapper reference(config, camera);
  config.integration = MapConfig::Integration::kProjective;
  Mapper fast(config, camera);
  EXPECT_EQ(reference.integrate(frame, pose).status, FrameStatus::kMapped);
  {
    os::AllocationScope scope;
    EXPECT_EQ(fast.integrate(frame, pose).status, FrameStatus::kMapped);
    EXPECT_EQ(scope.counted().allocations, 0);
  }
  Agreement a;
  const LocalGrid& r = reference.local_grid();
  const LocalGrid& f = fast.local_grid();
  const auto [nx, ny, nz] = r.dims();
  for (std::size_t i = 0; i < r.cell_count(); ++i) {
    if (region) {
      const auto x = static_cast<int>(i % static_cast<std::size_t>(nx));
      const auto y =
          static_cast<int>(i / static_cast<std::size_t>(nx) % static_cast<std::size_t>(ny));
      const auto z =
          static_cast<int>(i / (static_cast<std::size_t>(nx) * static_cast<std::size_t>(ny)));
      const CellIndex& o = r.origin();
      if (!region(reference.cell_center({o.x + x, o.y + y, o.z + z}))) continue;
    }
    const int rv = r.data()[i] == kUntouched ? 0 : r.data()[i];
    const int fv = f.data()[i] == kUntouched ? 0 : f.data()[i];
    if (rv == 0 && fv == 0) continue;
    ++a.touched;
    if ((rv > 0) == (fv > 0) && (rv < 0) == (fv < 0)) ++a.same_sign;
    ++a.kinds[(rv > 0) - (rv < 0) + 1][(fv > 0) - (fv < 0) + 1];
    if (rv > 0) {
      ++a.occupied_reference;
      if (fv <= 0 && rv - fv > 1) ++a.occupied_missed;
    }
    if (rv == 0 && fv < -1) ++a.free_where_none;
    a.above_reference_sum += std::max(fv - rv, 0);
    if (fv > rv + 1) ++a.above_reference;
    // A reference 0 is a ray whose end only touches the cell (m̂ = 0 at d + Δd): a
    // convention of the traversal, left out here (it is in the sign figures above).
    if (r.data()[i] != kUntouched && f.data()[i] != kUntouched && fv < rv && rv != 0) {
      ++a.below_reference;
      a.largest_shortfall = std::max(a.largest_shortfall, rv - fv);
    }
  }
  return a;
}

void expect_agreement(const Agreement& a, const std::string& what, double min_same = 0.999) {
  const double same = static_cast<double>(a.same_sign) / static_cast<double>(a.touched);
  std::printf(
      "[ %s ] touched %lld, same sign %.3f%%, occupied (reference) %lld, missed %lld, free where "
      "the reference has 0 %lld, below the reference %lld (by up to %d/64)\n",
      what.c_str(), static_cast<long long>(a.touched), 100.0 * same,
      static_cast<long long>(a.occupied_reference), static_cast<long long>(a.occupied_missed),
      static_cast<long long>(a.free_where_none), static_cast<long long>(a.below_reference),
      a.largest_shortfall);
  std::printf(
      "  above the reference by more than a step: %lld (by %lld/64 in all); reference -,0,+ rows x "
      "fast -,0,+ columns: "
      "%lld %lld %lld | %lld %lld %lld | %lld %lld %lld\n",
      static_cast<long long>(a.above_reference), static_cast<long long>(a.above_reference_sum),
      (long long)a.kinds[0][0], (long long)a.kinds[0][1], (long long)a.kinds[0][2],
      (long long)a.kinds[1][0], (long long)a.kinds[1][1], (long long)a.kinds[1][2],
      (long long)a.kinds[2][0], (long long)a.kinds[2][1], (long long)a.kinds[2][2]);
  EXPECT_GT(a.touched, 1000);
  EXPECT_GE(same, min_same) << what;
  EXPECT_EQ(a.occupied_missed, 0) << what;
  // Free where the reference has 0 (no ray crosses, or only a ray's end): a
  // free value there would erase what earlier frames saw.
  EXPECT_EQ(a.free_where_none, 0) << what;
  // The value is the upper bound wherever the sign allows: never below the
  // reference's, but for float rounding at the last 1/64 step.
  EXPECT_LE(a.largest_shortfall, 1) << what;
}

// Both paths over four frames of a generated flight (640x480, every third of its
// trajectory, noise from `seed`), with the config its scenario names, set to
// `see_through` (and `see_through_behind`); only the cells `region` accepts,
// when given. A flight that cannot be made touches no cell (and fails).
Agreement flight_agreement(const char* name, std::uint64_t seed, double see_through,
                           double see_through_behind = -1.0, const CellRegion& region = nullptr) {
  sim::Scenario scenario;
  std::string error;
  MapConfig config;
  if (!sim::make_scenario(name, {640, 1.0}, &scenario, &error) ||
      !hal::load_map_config(testing::source_path(scenario.config), &config, &error)) {
    ADD_FAILURE() << name << ": " << error;
    return {};
  }
  config.see_through = see_through;
  config.see_through_behind = see_through_behind;
  const std::size_t pixels = 640 * 480;
  std::vector<std::uint16_t> depth(pixels);
  std::vector<std::uint8_t> left(pixels);
  sim::Rng rng(seed);
  Agreement total;
  for (std::size_t k = 0; k < scenario.trajectory.size(); k += scenario.trajectory.size() / 3) {
    const auto& pose = scenario.trajectory[k].world_T_camera;
    sim::render(scenario.scene, scenario.camera, pose, sim::RenderOptions{}, rng, depth.data(),
                left.data());
    total.add(compare_frame(config, scenario.camera, {depth.data(), left.data(), 640, 480}, pose,
                            region));
  }
  return total;
}

TEST(Projective, AgreesWithReferenceOnGeneratedFrames) {
  for (const char* name : {"posts-through", "treeline", "bushes", "posts-around"}) {
    expect_agreement(flight_agreement(name, 21, 0.0), name);
  }
}

TEST(Projective, AgreesWithReferenceSeeingThrough) {
  // MapConfig::see_through as paper-flight2 ships it: both paths free the cells a
  // ray crossed wholly free where no ray came near its depth (hedge: the gaps
  // between bushes; posts: the cells beside them), and keep what rays end in.
  MapConfig flight2;
  std::string error;
  ASSERT_TRUE(
      hal::load_map_config(testing::source_path("config/paper-flight2.yaml"), &flight2, &error))
      << error;
  ASSERT_GT(flight2.see_through, 0.0) << "paper-flight2 ships without it";
  for (const char* name : {"hedge", "posts-through", "treeline-dense"}) {
    expect_agreement(flight_agreement(name, 23, flight2.see_through, flight2.see_through_behind),
                     std::string(name) + " seeing through");
  }
}

TEST(Projective, AgreesWithReferenceSeeingThroughOnMoreFlights) {
  // As above on more noise: where m̂ lies on a Q6 step's edge the paths may
  // round apart (see the top), and a ray that grazes a cell's edge (a thousandth
  // of a cell) or ends exactly where its free part does (m̂ on -1's step edge)
  // must not let the fast path see through a cell the reference keeps.
  MapConfig flight2;
  std::string error;
  ASSERT_TRUE(
      hal::load_map_config(testing::source_path("config/paper-flight2.yaml"), &flight2, &error))
      << error;
  for (const char* name : {"hedge", "treeline-dense", "treeline"}) {
    for (std::uint64_t seed = 24; seed <= 31; ++seed) {
      expect_agreement(
          flight_agreement(name, seed, flight2.see_through, flight2.see_through_behind),
          std::string(name) + " seeing through, noise " + std::to_string(seed));
    }
  }
}

TEST(Projective, GapsSeenThroughTakeTheRaysExactValue) {
  // Between the bushes of a hedge the footprint's depths (the bushes beside a
  // gap) bound a cell's value higher than any ray that crosses it; frame after
  // frame that excess fills the gap. A cell seen through and kept takes the
  // rays' exact maximum, as the reference does. Over the gaps' cells of three
  // flights the fast values exceed the reference's by 150/64 in all (217/64
  // when every kept cell takes the bound).
  MapConfig flight2;
  std::string error;
  ASSERT_TRUE(
      hal::load_map_config(testing::source_path("config/paper-flight2.yaml"), &flight2, &error))
      << error;
  sim::Scenario hedge;
  ASSERT_TRUE(sim::make_scenario("hedge", {640, 1.0}, &hedge, &error)) << error;
  // In a gap: between two bushes along the row, at least 0.5 m from each.
  const CellRegion in_a_gap = [&](const Eigen::Vector3d& c) {
    if (c.z() < 0.25 || c.z() > 1.75) return false;
    bool beside_bushes = false;
    for (const sim::Box& b : hedge.scene.boxes) {
      if (c.x() < b.min.x() || c.x() > b.max.x()) continue;
      if (c.y() > b.min.y() - 0.5 && c.y() < b.max.y() + 0.5) return false;
      beside_bushes = true;
    }
    return beside_bushes;
  };
  Agreement gaps;
  for (const std::uint64_t seed : {23, 24, 25}) {
    gaps.add(
        flight_agreement("hedge", seed, flight2.see_through, flight2.see_through_behind, in_a_gap));
  }
  expect_agreement(gaps, "hedge gaps");
  EXPECT_LE(gaps.above_reference_sum, 180);
}

TEST(Projective, NoValueWhereNoRayCrosses) {
  // Missing depth inside valid depth (stereo fails on thin or textureless
  // parts): the footprint box of a cell seen through a hole holds valid pixels
  // whose rays pass beside the cell. The reference draws nothing there; neither
  // may the fast path (a free value would erase what earlier frames saw).
  sim::Scenario scenario;
  std::string error;
  ASSERT_TRUE(sim::make_scenario("treeline", {320, 1.0}, &scenario, &error)) << error;
  MapConfig config;
  ASSERT_TRUE(hal::load_map_config(testing::source_path(scenario.config), &config, &error))
      << error;
  const CameraModel& camera = scenario.camera;
  std::vector<std::uint16_t> depth(static_cast<std::size_t>(camera.width * camera.height));
  std::vector<std::uint8_t> left(depth.size());
  sim::Rng rng(11);
  Agreement total;
  for (std::size_t k = 0; k < scenario.trajectory.size(); k += scenario.trajectory.size() / 3) {
    const auto& pose = scenario.trajectory[k].world_T_camera;
    sim::render(scenario.scene, camera, pose, sim::RenderOptions{}, rng, depth.data(), left.data());
    // Holes of 2..9 pixels square and one-pixel "wires", a fifth of the image.
    for (int hole = 0; hole < 400; ++hole) {
      const int side = 2 + static_cast<int>(rng.uniform() * 8.0);
      const bool wire = hole % 8 == 0;
      const int x0 = static_cast<int>(rng.uniform() * (camera.width - side));
      const int y0 = static_cast<int>(rng.uniform() * (camera.height - side));
      for (int y = y0; y < y0 + side; ++y)
        for (int x = x0; x < (wire ? camera.width : x0 + side); ++x)
          if (!wire || y == y0) depth[static_cast<std::size_t>(y * camera.width + x)] = 0;
    }
    const Agreement a =
        compare_frame(config, camera, {depth.data(), nullptr, camera.width, camera.height}, pose);
    total.add(a);
  }
  expect_agreement(total, "treeline with holes");
}

TEST(Projective, TinyImagesAgreeToo) {
  // Images narrower than one vector load (eight codes) take the scalar paths;
  // under ASan any read past a row would show. Crops of a 64x48 rendering, the
  // camera model shifted to match: with its focal length of 67 px the depth
  // uncertainty Δd is ten times the 640x480 camera's, so that m̂(b; d) of depths
  // beyond the cell is no longer monotone in d (the largest depth can give the
  // highest value: both ends of a range count).
  sim::Scenario scenario;
  std::string error;
  ASSERT_TRUE(sim::make_scenario("posts-through", {64, 1.0}, &scenario, &error)) << error;
  MapConfig config;
  ASSERT_TRUE(hal::load_map_config(testing::source_path(scenario.config), &config, &error))
      << error;
  const CameraModel& full = scenario.camera;
  std::vector<std::uint16_t> depth(static_cast<std::size_t>(full.width * full.height));
  std::vector<std::uint8_t> left(depth.size());
  sim::Rng rng(3);
  for (const int width : {1, 2, 5, 7, 8, 9, 64}) {
    const int height = std::max(1, width * 3 / 4);
    CameraModel camera = full;
    camera.width = width;
    camera.height = height;
    const int x_off = (full.width - width) / 2, y_off = (full.height - height) / 2;
    camera.cx = full.cx - x_off;
    camera.cy = full.cy - y_off;
    std::vector<std::uint16_t> crop_depth(static_cast<std::size_t>(width * height));
    std::vector<std::uint8_t> crop_left(crop_depth.size());
    Agreement total;
    for (std::size_t k = 0; k < scenario.trajectory.size(); k += scenario.trajectory.size() / 4) {
      const auto& pose = scenario.trajectory[k].world_T_camera;
      sim::render(scenario.scene, full, pose, sim::RenderOptions{}, rng, depth.data(), left.data());
      for (int y = 0; y < height; ++y)
        for (int x = 0; x < width; ++x) {
          const std::size_t from = static_cast<std::size_t>((y + y_off) * full.width + x + x_off);
          crop_depth[static_cast<std::size_t>(y * width + x)] = depth[from];
          crop_left[static_cast<std::size_t>(y * width + x)] = left[from];
        }
      const Agreement a =
          compare_frame(config, camera, {crop_depth.data(), crop_left.data(), width, height}, pose);
      total.add(a);
    }
    std::printf("[ %dx%d ] touched %lld, same sign %lld, occupied missed %lld, shortfall %d/64\n",
                width, height, static_cast<long long>(total.touched),
                static_cast<long long>(total.same_sign),
                static_cast<long long>(total.occupied_missed), total.largest_shortfall);
    EXPECT_GT(total.touched, 0) << width;
    if (width < full.width) {
      EXPECT_EQ(total.occupied_missed, 0) << width;
      EXPECT_LE(total.largest_shortfall, 1) << width;
    } else {
      // The whole 64x48 frame: one cell of 181k (ref 55/64, fast 0) where a ray
      // recomputed in double crosses nothing positive: the reference's float
      // traversal, 35 m out, put a peak one cell over. Allowed: 1 in 10^4.
      EXPECT_LE(total.occupied_missed * 10000, total.touched) << width;
    }
  }
}

TEST(Projective, AgreesWithReferenceOnRealFrames) {
  const std::string dir = std::string(ZONEMAP_SHARED_DATA_DIR) + "/redkitchen-0000-0059";
  if (!std::filesystem::exists(dir + "/depth.txt")) {
    GTEST_SKIP() << "real test data absent: " << dir;
  }
  MapConfig config;
  std::string error;
  ASSERT_TRUE(
      hal::load_map_config(testing::source_path("config/indoor-kinect.yaml"), &config, &error));
  replay::ReplaySequence sequence;
  ASSERT_TRUE(sequence.open(dir, "", config, &error)) << error;
  hal::CameraFrame frame = sequence.make_frame();
  Agreement total;
  for (std::size_t i = 0; i < sequence.frame_count(); i += 15) {
    ASSERT_TRUE(sequence.read(i, &frame, &error)) << error;
    Eigen::Isometry3d pose;
    ASSERT_NE(sequence.poses().lookup(frame.time_s, &pose), PoseLookup::kNoPose);
    const CameraModel& camera = sequence.camera();
    const Agreement a = compare_frame(
        config, camera, {frame.depth.data(), nullptr, camera.width, camera.height}, pose);
    total.add(a);
  }
  // Measured 100.000% (one cell of 217k: reference 0, fast occupied). Before
  // free cells needed a crossing ray it was 98.65%: cells at the edges of missing
  // depth called free through the footprint box's valid pixels.
  expect_agreement(total, "redkitchen");
}

}  // namespace
}  // namespace zonemap
