#include "hal/mavlink/tlog_writer.hpp"

#include <algorithm>
#include <cmath>

namespace zonemap::mavlink {

TlogWriter::~TlogWriter() {
  close();
}

void TlogWriter::close() {
  if (file_ != nullptr) std::fclose(file_);
  file_ = nullptr;
}

bool TlogWriter::open(const std::string& path, std::string* error) {
  file_ = std::fopen(path.c_str(), "wb");
  if (file_ == nullptr) {
    *error = path + ": cannot write";
    return false;
  }
  return true;
}

bool TlogWriter::send(const std::uint8_t* datagram, std::size_t size, double now_s) {
  if (file_ == nullptr) return false;
  const auto usec = static_cast<std::uint64_t>(std::llround(std::max(now_s, 0.0) * 1e6));
  std::uint8_t stamp[8];
  for (int i = 0; i < 8; ++i) stamp[i] = static_cast<std::uint8_t>(usec >> (56 - 8 * i));
  if (std::fwrite(stamp, 1, sizeof stamp, file_) != sizeof stamp) return false;
  if (std::fwrite(datagram, 1, size, file_) != size) return false;
  ++messages_;
  return true;
}

}  // namespace zonemap::mavlink
