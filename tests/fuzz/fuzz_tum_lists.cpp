// TUM text lists: depth.txt-style frame lists and groundtruth.txt trajectories,
// from memory through the same parsers the file loaders use.
#include <sstream>
#include <vector>

#include "hal/replay/sequence.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  std::vector<zonemap::replay::FrameListEntry> entries;
  std::string error;
  std::istringstream list(text);
  zonemap::replay::parse_frame_list(list, "fuzz.txt", "/nonexistent", &entries, &error);
  zonemap::PoseTrack track(0.1, 0.02);
  int rejected = 0;
  std::vector<std::string> warnings;
  std::istringstream trajectory(text);
  zonemap::replay::parse_trajectory(trajectory, "fuzz.txt", &track, &rejected, &warnings, &error);
  return 0;
}
