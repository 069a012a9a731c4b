#include "hal/can/can_pose_source.hpp"

#include <cerrno>
#include <cstring>

#include "hal/can/candump.hpp"

namespace zonemap::can {

SocketCanPoseSource::SocketCanPoseSource(const std::string& interface, const InsCanConfig& profile,
                                         const InsGateConfig& gate,
                                         const Eigen::Isometry3d& body_T_camera,
                                         double time_offset_s)
    : decoder_(profile),
      link_(interface, decoder_.ids(), profile.extended_ids),
      filter_(gate, body_T_camera, time_offset_s, "INS over SocketCAN") {}

hal::PollResult SocketCanPoseSource::poll(hal::PoseSink& sink, int wait_ms) {
  const double now = os::monotonic_now_s();
  if (!link_.ensure_open(now)) {
    filter_.log().log(hal::LogReason::kLinkDown, now, name(), link_.last_error());
    return hal::PollResult::kIdle;
  }
  if (wait_ms > 0 && !link_.wait_readable(wait_ms)) return hal::PollResult::kIdle;
  bool got = false;
  // Bounded: at most 256 frames per call, the rest stay queued in the socket.
  for (int i = 0; i < 256; ++i) {
    CanFrame frame;
    const CanIo io = link_.receive(&frame, now);
    if (io == CanIo::kDown) {
      ++link_errors_;
      filter_.log().log(hal::LogReason::kLinkDown, now, name(), link_.last_error());
      break;
    }
    if (io != CanIo::kOk) break;
    got = true;
    InsSolution solution;
    if (decoder_.feed(frame, &solution)) filter_.pass(solution, sink, now);
  }
  return got ? hal::PollResult::kGotData : hal::PollResult::kIdle;
}

hal::PoseSourceCounters SocketCanPoseSource::counters() const {
  hal::PoseSourceCounters c;
  const InsCanCounters& d = decoder_.counters();
  c.messages = d.frames;
  c.malformed = d.bad_dlc + d.bad_frame_type + d.orphan_parts + d.incomplete_sets + d.mixed_sets;
  c.solutions = d.solutions;
  c.poses_out = filter_.poses_out();
  c.link_errors = link_errors_;
  c.gate = filter_.gate_counters();
  return c;
}

CandumpPoseSource::CandumpPoseSource(const InsCanConfig& profile, const InsGateConfig& gate,
                                     const Eigen::Isometry3d& body_T_camera, double time_offset_s)
    : decoder_(profile), filter_(gate, body_T_camera, time_offset_s, "INS candump log") {}

CandumpPoseSource::~CandumpPoseSource() {
  if (file_ != nullptr) std::fclose(file_);
}

bool CandumpPoseSource::open(const std::string& path, std::string* error) {
  file_ = std::fopen(path.c_str(), "r");
  if (file_ == nullptr) {
    *error = path + ": " + std::strerror(errno);
    return false;
  }
  path_ = path;
  return true;
}

hal::PollResult CandumpPoseSource::poll(hal::PoseSink& sink, int /*wait_ms*/) {
  if (file_ == nullptr) return hal::PollResult::kEnd;
  char line[512];
  bool got = false;
  for (int i = 0; i < 4096; ++i) {  // bounded per call
    if (std::fgets(line, sizeof line, file_) == nullptr) return hal::PollResult::kEnd;
    ++lines_;
    std::size_t length = std::strlen(line);
    while (length > 0 && (line[length - 1] == '\n' || line[length - 1] == '\r')) --length;
    CanFrame frame;
    const char* why = nullptr;
    const CandumpLine kind = parse_candump_line({line, length}, &frame, nullptr, &why);
    if (kind == CandumpLine::kMalformed) {
      ++malformed_;
      char what[160];
      std::snprintf(what, sizeof what, "%s:%lld: %s", path_.c_str(), static_cast<long long>(lines_),
                    why);
      filter_.log().log(hal::LogReason::kDamagedLogRecord, frame.time_s, name(), what);
      continue;
    }
    if (kind != CandumpLine::kFrame) continue;
    got = true;
    InsSolution solution;
    if (decoder_.feed(frame, &solution)) filter_.pass(solution, sink, frame.time_s);
  }
  return got ? hal::PollResult::kGotData : hal::PollResult::kIdle;
}

hal::PoseSourceCounters CandumpPoseSource::counters() const {
  hal::PoseSourceCounters c;
  const InsCanCounters& d = decoder_.counters();
  c.messages = d.frames;
  c.malformed =
      malformed_ + d.bad_dlc + d.bad_frame_type + d.orphan_parts + d.incomplete_sets + d.mixed_sets;
  c.solutions = d.solutions;
  c.poses_out = filter_.poses_out();
  c.gate = filter_.gate_counters();
  return c;
}

}  // namespace zonemap::can
