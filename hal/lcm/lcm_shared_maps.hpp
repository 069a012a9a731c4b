// Maps shared between vehicles over LCM: another vehicle's obstacle_map_t (its
// map channel), taken into this vehicle's world frame through both frames'
// geodetic origins and handed to the feature map's thread through a
// SharedMapInbox. Only what the sender measured is taken: its prior boxes (a
// survey, an earlier flight, a third vehicle's map) and ground are left out, so
// that two vehicles sharing both ways never echo each other's boxes back.
// Receiving runs on a thread of its own (LCM's receive path allocates; the
// mapping path never waits for it).
#pragma once

#include <atomic>
#include <cstdint>
#include <string>
#include <vector>

#include "hal/ins/pose_source.hpp"
#include "hal/lcm/lcm_link.hpp"
#include "hal/os/task.hpp"
#include "zonemap/common/geodetic.hpp"
#include "zonemap/features/shared_map_inbox.hpp"
#include "zonemap_lcm/obstacle_map_t.hpp"

namespace zonemap::lcm_link {

struct SharedMapsConfig {
  std::string url = "udpm://239.255.76.67:7667?ttl=0";
  std::vector<std::string> channels;  // one sender each: sender n is channels[n - 1]
  std::size_t max_boxes = 512;        // per map; more are left out (counted)
  // This vehicle: its name (a map it sent itself is refused) and world frame.
  std::string vehicle = "zonemap";
  Geodetic world_origin;
  bool world_z_up = true;
};

struct SharedMapCounters {
  std::int64_t maps = 0;               // taken into the inbox
  std::int64_t malformed = 0;          // not an obstacle_map_t (fingerprint, length)
  std::int64_t refused_no_origin = 0;  // the sender said no world origin
  std::int64_t refused_own = 0;        // sent by this vehicle (a channel looping back)
  std::int64_t refused_frame = 0;      // a frame that is neither NED nor z up
  std::int64_t no_slot = 0;  // the feature map's thread held every slot (the next map wins)
  std::int64_t boxes_taken = 0;
  std::int64_t boxes_not_measured = 0;  // the sender's prior or ground boxes
  std::int64_t boxes_rejected = 0;      // not a number, inside out, > 1 km, below -1 km, too far
  std::int64_t boxes_over_capacity = 0;
};

// One message into an inbox slot: the frame change and every check, no thread
// (tests and fuzzing call it directly).
class SharedMapDecoder {
 public:
  explicit SharedMapDecoder(const SharedMapsConfig& config);
  // Fills `out` (count, boxes) from the bytes of sender `source`; false when the
  // whole message is refused (counted). Boxes that fail a check are left out.
  bool decode(const void* data, std::size_t size, SharedMapUpdate* out, double now_s);
  const SharedMapCounters& counters() const { return counters_; }
  SharedMapCounters& counters() { return counters_; }

 private:
  bool take_box(const zonemap_lcm::obstacle_box_t& in, bool sender_z_up,
                const LocalTangentPlane& sender, Eigen::Vector3d* min, Eigen::Vector3d* max);

  SharedMapsConfig config_;
  LocalTangentPlane own_;
  zonemap_lcm::obstacle_map_t message_;  // decoded into (LCM's decoder sizes its vectors)
  SharedMapCounters counters_;
  hal::RateLimitedLog log_;
  char why_[192] = {};
};

class LcmSharedMapReceiver {
 public:
  LcmSharedMapReceiver(const SharedMapsConfig& config, SharedMapInbox& inbox);
  ~LcmSharedMapReceiver();
  LcmSharedMapReceiver(const LcmSharedMapReceiver&) = delete;
  LcmSharedMapReceiver& operator=(const LcmSharedMapReceiver&) = delete;
  void start();
  void stop();
  // The receiving thread's counts: read after stop().
  const SharedMapCounters& counters() const { return decoder_.counters(); }
  std::int64_t start_failures() const { return start_failures_.load(std::memory_order_relaxed); }

 private:
  struct Subscription {
    LcmSharedMapReceiver* self;
    std::uint8_t source;
  };
  static void on_message(const lcm_recv_buf_t* rbuf, const char* channel, void* user);
  void receive(std::uint8_t source, const void* data, std::size_t size);
  void run();

  SharedMapsConfig config_;
  SharedMapInbox& inbox_;
  SharedMapDecoder decoder_;
  std::vector<Subscription> subscriptions_;
  SharedMapUpdate* held_ = nullptr;  // the receiving thread's slot, between messages
  std::atomic<bool> stop_{false};
  os::Task thread_;
  std::atomic<std::int64_t> start_failures_{0};
};

}  // namespace zonemap::lcm_link
