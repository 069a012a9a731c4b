// Shared by the libFuzzer targets: the decoders of files take a path, so the
// input is written to a scratch file first (one per process).
#pragma once

#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

namespace zonemap::fuzz {

// In memory (/dev/shm) when there is one: a file per input costs less there.
inline std::string scratch_file(const char* suffix) {
  const char* dir = access("/dev/shm", W_OK) == 0 ? "/dev/shm" : std::getenv("TMPDIR");
  return std::string(dir != nullptr ? dir : "/tmp") + "/zonemap-fuzz-" + std::to_string(getpid()) +
         suffix;
}

inline const std::string& write_scratch(const std::uint8_t* data, std::size_t size,
                                        const char* suffix) {
  static const std::string path = scratch_file(suffix);
  std::FILE* f = std::fopen(path.c_str(), "wb");
  if (f != nullptr) {
    if (size > 0) std::fwrite(data, 1, size, f);
    std::fclose(f);
  }
  return path;
}

}  // namespace zonemap::fuzz
