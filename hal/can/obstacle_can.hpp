// Obstacle boxes to the flight controller over CAN (layout: config/can/zonemap-obstacles.dbc).
// One map update is BEGIN, then BOX_MIN + BOX_MAX per box (+ BOX_AGE for a box
// not seen for over a second, or from a prior map and not yet confirmed by a
// view (PRIOR = 1): the frames stay two per box while the vehicle looks at what
// it flies towards), then END; BEGIN and
// END carry the same generation counter, so the receiver knows when it holds a
// complete update and which boxes belong together. Corners are decimetres
// relative to an anchor point (multiples of 100 m, in BEGIN) in the map's world
// frame, so 16-bit fields reach 3.2 km around the anchor anywhere on a flight.
// When the bus budget is short the nearest boxes go first; END says how many
// boxes the map held, whether the update was cut short and which way the world's
// z axis points.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>

#include <Eigen/Core>

#include "hal/can/can_frame.hpp"
#include "hal/can/can_signals.hpp"
#include "zonemap/features/feature_map.hpp"

namespace zonemap::can {

struct ObstacleCanConfig {
  std::uint32_t base_id = 0x320;  // BEGIN, BOX_MIN, BOX_MAX, END, BOX_AGE = base .. base + 4
  bool extended_ids = false;
  double rate_hz = 5.0;              // map updates per second
  double max_frames_per_s = 1000.0;  // the bus budget for this output
  bool include_ground = false;       // ground boxes too (obstacles always)
};

inline constexpr std::uint8_t kObstacleUpdateTruncated = 1u << 0;   // budget: nearest only
inline constexpr std::uint8_t kObstacleUpdateOutOfRange = 1u << 1;  // some beyond 3.2 km
// The boxes' world frame, said in every update: set = z down (NED), clear = z up.
// Boxes are world-frame, so no camera mount enters them.
inline constexpr std::uint8_t kObstacleWorldZDown = 1u << 2;
// A box last seen longer ago than this gets a BOX_AGE frame (AGE: seconds since
// it last stood in the camera's view, 0.1 s, saturating at 6553.5 s); a box
// without one was seen within this time of the update.
inline constexpr double kObstacleAgeReportedS = 1.0;

std::span<const MessageSpec> obstacle_messages();

struct ObstacleCanCounters {
  std::int64_t updates = 0;
  std::int64_t boxes_sent = 0;
  std::int64_t boxes_over_budget = 0;  // left out of an update (farthest first)
  std::int64_t boxes_out_of_range = 0;
  std::int64_t ages_sent = 0;  // BOX_AGE frames
};

class ObstacleCanEncoder {
 public:
  explicit ObstacleCanEncoder(const ObstacleCanConfig& config);

  // Frames one update may use (from the budget and the rate).
  std::size_t frames_per_update() const { return frames_per_update_; }

  // Encodes one update of `count` boxes into `out` (room for frames_per_update()),
  // nearest to `vehicle` first. `order` is scratch room for `count` indices
  // (reserved by the caller: no allocation). Returns the number of frames.
  std::size_t encode(const ObstacleBox* boxes, std::size_t count, const Eigen::Vector3d& vehicle,
                     bool world_z_up, double time_s, std::uint32_t* order, CanFrame* out);
  const ObstacleCanCounters& counters() const { return counters_; }

 private:
  ObstacleCanConfig config_;
  std::size_t frames_per_update_ = 0;
  std::uint16_t generation_ = 0;
  ObstacleCanCounters counters_;
};

// The receiver's side (the flight controller; here for tests and tools).
struct DecodedObstacleBox {
  std::uint16_t id = 0;
  bool ground = false;
  Eigen::Vector3d min = Eigen::Vector3d::Zero(), max = Eigen::Vector3d::Zero();
  double age_s = 0.0;  // from BOX_AGE; 0: seen within kObstacleAgeReportedS
  bool prior = false;  // from BOX_AGE: a prior map's box no view has confirmed
};

class ObstacleCanDecoder {
 public:
  explicit ObstacleCanDecoder(std::uint32_t base_id = 0x320) : base_id_(base_id) {}
  // Returns true when `frame` completed an update (boxes(), flags(), total()).
  bool feed(const CanFrame& frame);
  std::span<const DecodedObstacleBox> boxes() const { return {boxes_, count_}; }
  std::uint16_t generation() const { return generation_; }
  std::uint8_t flags() const { return flags_; }
  int total_in_map() const { return total_; }
  std::int64_t broken_updates() const { return broken_; }

 private:
  static constexpr std::size_t kMaxBoxes = 1024;
  std::uint32_t base_id_;
  bool open_ = false;
  std::uint16_t generation_ = 0;
  int announced_ = 0, total_ = 0;
  std::uint8_t flags_ = 0;
  Eigen::Vector2d anchor_ = Eigen::Vector2d::Zero();
  DecodedObstacleBox boxes_[kMaxBoxes];
  std::size_t count_ = 0;
  bool have_min_ = false;
  std::int64_t broken_ = 0;
};

}  // namespace zonemap::can
