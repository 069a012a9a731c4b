// When the live zones are extracted between discards (paper §IV-A extracts a zone
// before its grid goes; the live ones are extracted periodically too, so that
// their objects reach the outputs): one zone every few mapped frames, round robin,
// so that each comes round about every `extract_every_frames` and no frame pays
// for all of them. The single-threaded replay and the pipeline share it, which
// keeps their maps identical.
#pragma once

#include <algorithm>
#include <cstdint>

#include "zonemap/common/config.hpp"

namespace zonemap {

class ExtractionSchedule {
 public:
  explicit ExtractionSchedule(int extract_every_frames)
      : stride_(std::max(1, extract_every_frames / kZonesHeld)) {}

  // After the frames_mapped-th mapped frame: which live zone (in ZoneMap order)
  // to extract now, or -1.
  int after_frame(std::int64_t frames_mapped, int live_zones) {
    if (frames_mapped % stride_ != 0 || live_zones <= 0) return -1;
    return static_cast<int>(next_++ % static_cast<std::uint64_t>(live_zones));
  }

 private:
  int stride_;
  std::uint64_t next_ = 0;
};

}  // namespace zonemap
