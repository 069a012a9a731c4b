// TUM text lists: depth.txt-style frame lists and groundtruth.txt trajectories.
#include <vector>

#include "hal/replay/sequence.hpp"
#include "tests/fuzz/fuzz_support.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string& path = zonemap::fuzz::write_scratch(data, size, ".txt");
  std::vector<zonemap::hal::FrameListEntry> entries;
  std::string error;
  zonemap::hal::load_frame_list(path, "/nonexistent", &entries, &error);
  zonemap::PoseTrack track(0.1, 0.02);
  int rejected = 0;
  std::vector<std::string> warnings;
  zonemap::hal::load_trajectory(path, &track, &rejected, &warnings, &error);
  return 0;
}
