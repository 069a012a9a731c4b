// LCM log files (lcm-logger) read by the log pose source, from memory through the
// same bounded reader the file path uses.
#include "hal/lcm/lcm_link.hpp"

namespace {
struct NullSink final : zonemap::hal::PoseSink {
  void push(const zonemap::PoseSample&) override {}
};
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  zonemap::lcm_link::LcmLogPoseSource source("INS_STATE", false, {}, Eigen::Isometry3d::Identity(),
                                             0.0);
  source.open_memory(data, size);
  NullSink sink;
  for (int i = 0; i < 64 && source.poll(sink, 0) != zonemap::hal::PollResult::kEnd; ++i) {
  }
  return 0;
}
