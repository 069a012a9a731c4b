// INS poses from CAN: live over SocketCAN, or replayed from a candump log, both
// through the same profile decoder (hal/can/ins_can) and plausibility gate.
#pragma once

#include <cstdio>
#include <memory>
#include <string>

#include "hal/can/ins_can.hpp"
#include "hal/can/socketcan.hpp"
#include "hal/ins/pose_source.hpp"
#include "hal/os/clock.hpp"

namespace zonemap::can {

class SocketCanPoseSource final : public hal::PoseSource {
 public:
  // time_offset_s: added to the kernel receive time (CLOCK_REALTIME) to reach the
  // depth frames' clock; monotonic_offset() gives it for CLOCK_MONOTONIC frames.
  SocketCanPoseSource(const std::string& interface, const InsCanConfig& profile,
                      const InsGateConfig& gate, const Eigen::Isometry3d& body_T_camera,
                      double time_offset_s);
  hal::PollResult poll(hal::PoseSink& sink, int wait_ms) override;
  hal::PoseSourceCounters counters() const override;
  const char* name() const override { return "INS over SocketCAN"; }
  const CanLinkCounters& link_counters() const { return link_.counters(); }
  const InsCanCounters& decoder_counters() const { return decoder_.counters(); }
  static double monotonic_offset() { return os::monotonic_now_s() - os::realtime_now_s(); }

 private:
  InsCanDecoder decoder_;
  CanLink link_;
  hal::InsPoseFilter filter_;
  std::int64_t link_errors_ = 0;
};

class CandumpPoseSource final : public hal::PoseSource {
 public:
  CandumpPoseSource(const InsCanConfig& profile, const InsGateConfig& gate,
                    const Eigen::Isometry3d& body_T_camera, double time_offset_s);
  ~CandumpPoseSource() override;
  bool open(const std::string& path, std::string* error);
  // Reads the whole log (poses sorted by time are what a replay wants).
  hal::PollResult poll(hal::PoseSink& sink, int wait_ms) override;
  hal::PoseSourceCounters counters() const override;
  const char* name() const override { return "INS candump log"; }
  const InsCanCounters& decoder_counters() const { return decoder_.counters(); }

 private:
  InsCanDecoder decoder_;
  hal::InsPoseFilter filter_;
  std::FILE* file_ = nullptr;
  std::string path_;
  std::int64_t lines_ = 0, malformed_ = 0;
};

}  // namespace zonemap::can
