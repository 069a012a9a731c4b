// Recent INS poses, written by one thread (the pose source) and read by another
// (the mapper) without locks: a ring of samples, each guarded by a sequence
// number (odd while being written). A reader that races the writer on a slot sees
// the sequence change and retries that slot, a bounded number of times (then
// leaves that one sample out).
#pragma once

#include <array>
#include <atomic>
#include <cstddef>
#include <cstdint>

#include <Eigen/Geometry>

#include "zonemap/pose/pose_track.hpp"

namespace zonemap {

template <std::size_t Capacity>
class PoseBuffer {
  static_assert(Capacity >= 4, "room for interpolation");

 public:
  // Writer thread only. Samples must come in increasing time (the caller checks).
  void push(const PoseSample& sample) {
    const std::uint64_t n = count_.load(std::memory_order_relaxed);
    Slot& slot = slots_[n % Capacity];
    // Sequentially consistent throughout (no fences, which ThreadSanitizer cannot
    // follow): a reader that sees the same even sequence before and after its
    // copy saw no store of this write in between. Poses come at ~100 Hz: cheap.
    const std::uint32_t seq = slot.seq.load();
    slot.seq.store(seq + 1);  // odd: being written
    store(slot, sample, n);
    slot.seq.store(seq + 2);  // even: complete
    count_.store(n + 1, std::memory_order_release);
  }

  // One reader thread. Copies the newest samples (oldest first) into `track` (which
  // must have room, see PoseTrack::reserve) so that it can interpolate; returns
  // the time of the newest sample, or -inf when there is none.
  double snapshot(PoseTrack* track) const {
    track->clear();
    // Newest first: the newest sample is the one a fast writer overwrites last, so
    // "newest" never goes back between snapshots. If even it was overwritten (the
    // reader was descheduled for a whole lap), start again (bounded).
    std::uint64_t n = 0, first = 0, oldest_read = 0;
    for (int attempt = 0; attempt < 4; ++attempt) {
      n = count_.load(std::memory_order_acquire);
      if (n == 0) return -std::numeric_limits<double>::infinity();
      first = n > Capacity - 1 ? n - (Capacity - 1) : 0;  // one slot of slack
      oldest_read = n;
      if (read(slots_[(n - 1) % Capacity], n - 1, &scratch_[(n - 1) % Capacity])) {
        oldest_read = n - 1;
        break;
      }
    }
    if (oldest_read == n) return -std::numeric_limits<double>::infinity();
    // Older samples back to `first`; stop at the first one overwritten meanwhile
    // (everything older is gone too).
    while (oldest_read > first && read(slots_[(oldest_read - 1) % Capacity], oldest_read - 1,
                                       &scratch_[(oldest_read - 1) % Capacity])) {
      --oldest_read;
    }
    double newest = -std::numeric_limits<double>::infinity();
    for (std::uint64_t i = oldest_read; i < n; ++i) {
      const PoseSample& sample = scratch_[i % Capacity];
      // A sample not after the one before it follows a clock step the INS gate
      // adopted: the older clock's samples go, the newest clock's are kept.
      if (!track->samples().empty() && !(sample.time_s > track->samples().back().time_s)) {
        track->clear();
      }
      if (track->append(sample)) newest = sample.time_s;
    }
    return newest;
  }

  std::uint64_t count() const { return count_.load(std::memory_order_acquire); }

 private:
  // Samples are stored as atomics, so a racing read is not a data race; the
  // sequence number tells whether the copy is consistent.
  struct Slot {
    std::atomic<std::uint32_t> seq{0};
    std::array<std::atomic<double>, 8> values{};
    std::atomic<std::uint64_t> index{UINT64_MAX};  // which sample (0, 1, ...) it holds
  };
  static void store(Slot& slot, const PoseSample& s, std::uint64_t index) {
    slot.index.store(index);
    const double v[8] = {s.time_s,       s.position.x(), s.position.y(), s.position.z(),
                         s.attitude.x(), s.attitude.y(), s.attitude.z(), s.attitude.w()};
    for (std::size_t k = 0; k < 8; ++k) slot.values[k].store(v[k]);
  }
  static bool read(const Slot& slot, std::uint64_t index, PoseSample* out) {
    for (int attempt = 0; attempt < 4; ++attempt) {
      const std::uint32_t before = slot.seq.load();
      if (before & 1u) continue;
      double v[8];
      for (std::size_t k = 0; k < 8; ++k) v[k] = slot.values[k].load();
      const std::uint64_t held = slot.index.load();
      if (slot.seq.load() != before) continue;
      if (held != index) return false;
      out->time_s = v[0];
      out->position = Eigen::Vector3d(v[1], v[2], v[3]);
      out->attitude = Eigen::Quaterniond(v[7], v[4], v[5], v[6]);
      return true;
    }
    return false;
  }

  std::array<Slot, Capacity> slots_{};
  // The reader's copies (one reader thread; snapshot() is not re-entrant).
  mutable std::array<PoseSample, Capacity> scratch_{};
  std::atomic<std::uint64_t> count_{0};
};

}  // namespace zonemap
