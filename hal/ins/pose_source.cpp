#include "hal/ins/pose_source.hpp"

#include <algorithm>

namespace zonemap::hal {

void RateLimitedLog::log(LogReason reason, double now_s, const char* source, const char* what) {
  const int r = std::clamp(static_cast<int>(reason), 0, kReasons - 1);
  if (logged_[r] && now_s - last_s_[r] < interval_s_) {
    ++suppressed_[r];
    return;
  }
  if (suppressed_[r] > 0) {
    std::fprintf(stderr, "zonemap: %s: %s (and %lld more)\n", source, what,
                 static_cast<long long>(suppressed_[r]));
  } else {
    std::fprintf(stderr, "zonemap: %s: %s\n", source, what);
  }
  logged_[r] = true;
  last_s_[r] = now_s;
  suppressed_[r] = 0;
}

bool InsPoseFilter::pass(InsSolution solution, PoseSink& sink, double now_s) {
  solution.time_s += time_offset_s_;
  InsRejection why{};
  if (!gate_.check(solution, &why)) {
    log_.log(gate_reason(why), now_s, name_, to_string(why));
    return false;
  }
  sink.push(camera_pose_sample(solution, body_T_camera_));
  ++poses_out_;
  return true;
}

PoseLogRead read_to_end(PoseSource& log, PoseTrack* track) {
  struct TrackSink final : PoseSink {
    PoseTrack* track = nullptr;
    std::int64_t refused = 0;
    void push(const PoseSample& p) override {
      if (!track->append(p)) ++refused;
    }
  } sink;
  sink.track = track;
  while (log.poll(sink, 0) != PollResult::kEnd) {
  }
  PoseLogRead read;
  read.refused_by_track = sink.refused;
  read.counters = log.counters();
  return read;
}

}  // namespace zonemap::hal
