// A time watermark that one bad timestamp cannot move. Every stream of stamped
// items (depth frames, poses, INS solutions) must go forward in time; a single
// stamp far in the future used to become the watermark and refuse everything
// after it, a single stamp from the past was harmless only by luck.
//
// Rules, per offered stamp t against the watermark w (the newest accepted):
//   - not finite: refused;
//   - w < t <= w + max_step: accepted, w = t;
//   - otherwise (t <= w: past or repeated; t > w + max_step: future) it is refused
//     and held as a candidate run: later refused stamps that continue it (each
//     after the previous one, by at most max_step) lengthen the run. A run of
//     confirm_values stamps is a persistent change (the clock stepped, the INS
//     re-initialised): it is adopted, w = its last stamp, and counted.
//   - an accepted stamp ends any candidate run: a lone outlier costs only itself.
// A real step therefore costs at most confirm_values - 1 items on a live stream
// (a list read whole takes the run's items back: adopted_run_length()).
// Allocation-free, O(1) per stamp.
#pragma once

#include <cstddef>
#include <cstdint>

namespace zonemap {

struct TimeWatermarkConfig {
  double max_step_s = 2.0;  // the largest forward step taken as the stream going on
  int confirm_values = 3;   // stamps that continue each other before a step is adopted
  // Live streams adopt a clock that stepped back (the INS re-initialised). Lists
  // read whole (depth.txt, groundtruth.txt) do not: frames and poses are paired by
  // time, and two stretches of one clock would pair wrongly; a list whose clock
  // went back stays refused from there, said in the log.
  bool adopt_backward = true;
};

enum class TimeVerdict : std::uint8_t {
  kAccepted,
  kAdopted,  // accepted: the run it ends is adopted as the new clock
  kNotFinite,
  kRepeated,  // equal to the watermark
  kPast,      // before the watermark
  kFuture,    // more than max_step after it
};
const char* to_string(TimeVerdict verdict);
inline bool accepted(TimeVerdict v) {
  return v == TimeVerdict::kAccepted || v == TimeVerdict::kAdopted;
}

class TimeWatermark {
 public:
  explicit TimeWatermark(const TimeWatermarkConfig& config = {}) : config_(config) {}
  TimeVerdict offer(double time_s);
  bool has_value() const { return has_value_; }
  double newest() const { return newest_; }
  // Stamps in the candidate run that the last kAdopted ended, the adopted one
  // included (1 when nothing was held back).
  int adopted_run_length() const { return adopted_run_; }
  int run_length() const { return run_; }  // the candidate run held now (0: none)
  std::int64_t steps_adopted() const { return steps_; }
  void reset() { *this = TimeWatermark(config_); }

 private:
  TimeWatermarkConfig config_;
  bool has_value_ = false;
  double newest_ = 0.0;
  int run_ = 0;  // 0 = no candidate run
  double run_last_ = 0.0;
  int adopted_run_ = 1;
  std::int64_t steps_ = 0;
};

// A whole list of stamps in file order: per stamp the verdict a watermark gives,
// except that the stamps of a run that is then adopted are accepted too (a list
// loses nothing to a real forward step). Allocation-free.
void filter_time_list(const double* times, std::size_t count, const TimeWatermarkConfig& config,
                      TimeVerdict* verdicts);

}  // namespace zonemap
