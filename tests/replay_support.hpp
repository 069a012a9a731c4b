// The replay job as the tests set it up.
#pragma once

#include <string>

#include "tools/replay/replay_run.hpp"

namespace zonemap::testing {

// A sequence mapped with a configuration, without the start-up report or log.
inline tools::ReplayOptions quiet_replay(const std::string& sequence, const std::string& config) {
  tools::ReplayOptions options;
  options.sequence_dir = sequence;
  options.config_path = config;
  options.quiet = true;
  return options;
}

}  // namespace zonemap::testing
