#include "hal/can/candump_writer.hpp"

#include "hal/can/candump.hpp"

namespace zonemap::can {

CandumpWriter::~CandumpWriter() {
  close();
}

void CandumpWriter::close() {
  if (file_ != nullptr) std::fclose(file_);
  file_ = nullptr;
}

bool CandumpWriter::open(const std::string& path, std::string_view interface, std::string* error) {
  file_ = std::fopen(path.c_str(), "w");
  if (file_ == nullptr) {
    *error = path + ": cannot write";
    return false;
  }
  interface_ = interface;
  return true;
}

CanIo CandumpWriter::send(const CanFrame& frame, double now_s) {
  CanFrame stamped = frame;
  stamped.time_s = now_s;
  char line[96];
  const std::size_t n = format_candump_line(stamped, interface_, line, sizeof line);
  if (file_ == nullptr || n == 0) return CanIo::kDown;
  std::fprintf(file_, "%.*s\n", static_cast<int>(n), line);
  ++frames_;
  return CanIo::kOk;
}

}  // namespace zonemap::can
