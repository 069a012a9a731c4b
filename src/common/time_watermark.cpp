#include "zonemap/common/time_watermark.hpp"

#include <cmath>

namespace zonemap {

const char* to_string(TimeVerdict verdict) {
  switch (verdict) {
    case TimeVerdict::kAccepted:
      return "accepted";
    case TimeVerdict::kAdopted:
      return "accepted: the clock stepped (adopted after consistent stamps)";
    case TimeVerdict::kNotFinite:
      return "timestamp not finite";
    case TimeVerdict::kRepeated:
      return "timestamp repeated";
    case TimeVerdict::kPast:
      return "timestamp before the previous one";
    case TimeVerdict::kFuture:
      return "timestamp too far after the previous one";
  }
  return "?";
}

TimeVerdict TimeWatermark::offer(double t) {
  if (!std::isfinite(t)) return TimeVerdict::kNotFinite;
  if (!has_value_) {
    has_value_ = true;
    newest_ = t;
    return TimeVerdict::kAccepted;
  }
  const double step = t - newest_;
  if (step > 0.0 && step <= config_.max_step_s) {
    newest_ = t;
    run_ = 0;
    return TimeVerdict::kAccepted;
  }
  if (step <= 0.0 && !config_.adopt_backward) {
    return step == 0.0 ? TimeVerdict::kRepeated : TimeVerdict::kPast;  // the run is untouched
  }
  const bool continues_run = run_ > 0 && t > run_last_ && t - run_last_ <= config_.max_step_s;
  run_ = continues_run ? run_ + 1 : 1;
  run_last_ = t;
  if (run_ >= config_.confirm_values) {
    adopted_run_ = run_;
    run_ = 0;
    newest_ = t;
    ++steps_;
    return TimeVerdict::kAdopted;
  }
  if (step == 0.0) return TimeVerdict::kRepeated;
  return step < 0.0 ? TimeVerdict::kPast : TimeVerdict::kFuture;
}

void filter_time_list(const double* times, std::size_t count, const TimeWatermarkConfig& config,
                      TimeVerdict* verdicts) {
  TimeWatermark mark(config);
  std::size_t run_first = 0;  // the first stamp of the candidate run held now
  const auto in_run = [&config](TimeVerdict v) {
    return v == TimeVerdict::kFuture ||
           (config.adopt_backward && (v == TimeVerdict::kPast || v == TimeVerdict::kRepeated));
  };
  for (std::size_t i = 0; i < count; ++i) {
    verdicts[i] = mark.offer(times[i]);
    if (mark.run_length() == 1) run_first = i;  // a run starts (or replaces the one held)
    if (verdicts[i] != TimeVerdict::kAdopted) continue;
    // Every stamp held in the run since it started continues it: take them back.
    for (std::size_t k = run_first; k < i; ++k) {
      if (in_run(verdicts[k])) verdicts[k] = TimeVerdict::kAdopted;
    }
  }
}

}  // namespace zonemap
