// LCM log files (lcm-logger) read by the log pose source.
#include "hal/lcm/lcm_link.hpp"
#include "tests/fuzz/fuzz_support.hpp"

namespace {
struct NullSink final : zonemap::hal::PoseSink {
  void push(const zonemap::PoseSample&) override {}
};
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string& path = zonemap::fuzz::write_scratch(data, size, ".lcmlog");
  zonemap::lcm_link::LcmLogPoseSource source("INS_STATE", false, {}, Eigen::Isometry3d::Identity(),
                                             0.0);
  std::string error;
  if (!source.open(path, &error)) return 0;
  NullSink sink;
  for (int i = 0; i < 64 && source.poll(sink, 0) != zonemap::hal::PollResult::kEnd; ++i) {
  }
  return 0;
}
