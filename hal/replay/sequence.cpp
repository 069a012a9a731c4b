#include "hal/replay/sequence.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "hal/codec/png_io.hpp"
#include "hal/config/yaml_config.hpp"

namespace zonemap::replay {
namespace {

bool is_blank_or_comment(const std::string& line) {
  const auto first = line.find_first_not_of(" \t\r");
  return first == std::string::npos || line[first] == '#';
}

std::string join(const std::string& dir, const std::string& relative) {
  if (!relative.empty() && relative[0] == '/') return relative;
  return (std::filesystem::path(dir) / relative).string();
}

}  // namespace

bool load_frame_list(const std::string& list_path, const std::string& base_dir,
                     std::vector<FrameListEntry>* entries, std::string* error,
                     const TimeWatermarkConfig& time) {
  std::ifstream in(list_path);
  if (!in) {
    *error = list_path + ": cannot open";
    return false;
  }
  return parse_frame_list(in, list_path, base_dir, entries, error, time);
}

bool parse_frame_list(std::istream& in, const std::string& list_path, const std::string& base_dir,
                      std::vector<FrameListEntry>* entries, std::string* error,
                      const TimeWatermarkConfig& time) {
  entries->clear();
  std::string line;
  int number = 0;
  while (std::getline(in, line)) {
    ++number;
    if (is_blank_or_comment(line)) continue;
    std::istringstream fields(line);
    FrameListEntry entry;
    std::string stamp, relative;
    char* end = nullptr;
    if (!(fields >> stamp >> relative) ||
        (entry.time_s = std::strtod(stamp.c_str(), &end), end == stamp.c_str() || *end != '\0')) {
      *error = list_path + ":" + std::to_string(number) + ": expected 'timestamp path'";
      return false;
    }
    // A "nan" or "inf" stamp parses: the time filter refuses that frame alone.
    entry.path = join(base_dir, relative);
    entry.line = number;
    entries->push_back(std::move(entry));
  }
  std::vector<double> times(entries->size());
  std::vector<TimeVerdict> verdicts(entries->size());
  for (std::size_t i = 0; i < entries->size(); ++i) times[i] = (*entries)[i].time_s;
  filter_time_list(times.data(), times.size(), time, verdicts.data());
  for (std::size_t i = 0; i < entries->size(); ++i) {
    (*entries)[i].time_verdict = verdicts[i];
    (*entries)[i].time_in_order = accepted(verdicts[i]);
  }
  return true;
}

bool load_trajectory(const std::string& path, PoseTrack* track, int* rejected,
                     std::vector<std::string>* warnings, std::string* error,
                     const ListFilterConfig& filter, PoseListCounts* counts) {
  std::ifstream in(path);
  if (!in) {
    *error = path + ": cannot open";
    return false;
  }
  return parse_trajectory(in, path, track, rejected, warnings, error, filter, counts);
}

namespace {

// The poses of a list that pass the time filter and the plausibility gate, in
// order, into the track; each refusal counted and described.
void filter_poses(const std::vector<PoseSample>& samples, const std::vector<int>& lines,
                  const std::string& path, const ListFilterConfig& filter, PoseTrack* track,
                  int* rejected, std::vector<std::string>* warnings, PoseListCounts* counts) {
  std::vector<double> times(samples.size());
  std::vector<TimeVerdict> verdicts(samples.size());
  for (std::size_t i = 0; i < samples.size(); ++i) times[i] = samples[i].time_s;
  filter_time_list(times.data(), times.size(), filter.time, verdicts.data());
  InsGateConfig gate_config = filter.gate;
  gate_config.time.max_step_s = INFINITY;  // the list's time order is settled above
  InsGate gate(gate_config);
  const auto refuse = [&](std::size_t i, const char* reason, std::int64_t* counter) {
    ++*rejected;
    ++*counter;
    warnings->push_back(path + ":" + std::to_string(lines[i]) + ": pose rejected: " + reason);
  };
  for (std::size_t i = 0; i < samples.size(); ++i) {
    const PoseSample& p = samples[i];
    if (!p.position.allFinite() || !p.attitude.coeffs().allFinite() || !std::isfinite(p.time_s)) {
      refuse(i, "non-finite value", &counts->not_finite);
      continue;
    }
    if (std::fabs(p.attitude.norm() - 1.0) > 1e-3) {
      refuse(i, "quaternion is not unit length", &counts->quaternion);
      continue;
    }
    switch (verdicts[i]) {
      case TimeVerdict::kPast:
        refuse(i, "timestamp before the previous pose", &counts->time_past);
        continue;
      case TimeVerdict::kRepeated:
        refuse(i, "timestamp repeats the previous pose's", &counts->time_repeated);
        continue;
      case TimeVerdict::kFuture:
      case TimeVerdict::kNotFinite:
        refuse(i, "timestamp far after its neighbours (a lone outlier)", &counts->time_future);
        continue;
      case TimeVerdict::kAdopted:
      case TimeVerdict::kAccepted:
        break;
    }
    InsSolution solution;
    solution.time_s = p.time_s;
    solution.position_m = p.position;
    solution.attitude = p.attitude;
    solution.attitude_valid = solution.position_valid = true;
    InsRejection why = InsRejection::kCount;
    if (!gate.check(solution, &why)) {
      refuse(i, to_string(why), &counts->jump);
      continue;
    }
    if (!track->append(p)) refuse(i, "timestamp not after the previous pose", &counts->time_past);
  }
  counts->reanchors = gate.counters().reanchors;
  for (std::size_t i = 1; i < samples.size(); ++i) {
    if (verdicts[i] == TimeVerdict::kAdopted && verdicts[i - 1] != TimeVerdict::kAdopted) {
      ++counts->clock_steps;
    }
  }
}

}  // namespace

bool parse_trajectory(std::istream& in, const std::string& path, PoseTrack* track, int* rejected,
                      std::vector<std::string>* warnings, std::string* error,
                      const ListFilterConfig& filter, PoseListCounts* counts) {
  PoseListCounts local_counts;
  if (counts == nullptr) counts = &local_counts;
  std::vector<PoseSample> samples;
  std::vector<int> lines;
  std::string line;
  int number = 0;
  while (std::getline(in, line)) {
    ++number;
    if (is_blank_or_comment(line)) continue;
    std::istringstream fields(line);
    std::string tokens[8];
    double v[8];
    int count = 0;
    while (count < 8 && fields >> tokens[count]) ++count;
    std::string extra;
    if (count != 8 || (fields >> extra)) {
      *error = path + ":" + std::to_string(number) + ": expected 'timestamp tx ty tz qx qy qz qw'";
      return false;
    }
    for (int i = 0; i < 8; ++i) {
      // strtod accepts "nan" and "inf", which are then refused as non-finite.
      char* end = nullptr;
      v[i] = std::strtod(tokens[i].c_str(), &end);
      if (end == tokens[i].c_str() || *end != '\0') {
        *error = path + ":" + std::to_string(number) + ": '" + tokens[i] + "' is not a number";
        return false;
      }
    }
    PoseSample sample;
    sample.time_s = v[0];
    sample.position = Eigen::Vector3d(v[1], v[2], v[3]);
    sample.attitude = Eigen::Quaterniond(v[7], v[4], v[5], v[6]);
    samples.push_back(sample);
    lines.push_back(number);
  }
  filter_poses(samples, lines, path, filter, track, rejected, warnings, counts);
  return true;
}

bool ReplaySequence::open(const std::string& dir, const std::string& camera_path,
                          const MapConfig& config, std::string* error,
                          const hal::SequenceInsLog* ins_logs) {
  if (!std::filesystem::is_directory(dir)) {
    *error = dir + ": not a directory";
    return false;
  }
  const std::string camera_file = camera_path.empty() ? join(dir, "camera.yaml") : camera_path;
  if (!hal::load_camera_yaml(camera_file, &camera_, error)) return false;
  if (config.depth_scale_override > 0.0) camera_.depth_scale = config.depth_scale_override;

  ListFilterConfig filter;
  filter.time.max_step_s = config.timestamps.max_step_s;
  filter.time.confirm_values = config.timestamps.confirm_values;
  filter.gate.time = config.timestamps;  // INS logs: a live stream's rules
  if (!load_frame_list(join(dir, "depth.txt"), dir, &frames_, error, filter.time)) return false;

  // Optional left images, matched to depth frames by timestamp (same clock).
  left_paths_.assign(frames_.size(), std::string());
  const std::string left_list = join(dir, "left.txt");
  if (std::filesystem::exists(left_list)) {
    std::vector<FrameListEntry> lefts;
    if (!load_frame_list(left_list, dir, &lefts, error)) return false;
    std::sort(lefts.begin(), lefts.end(),
              [](const FrameListEntry& a, const FrameListEntry& b) { return a.time_s < b.time_s; });
    for (std::size_t i = 0; i < frames_.size(); ++i) {
      const double t = frames_[i].time_s;
      auto it = std::lower_bound(lefts.begin(), lefts.end(), t,
                                 [](const FrameListEntry& e, double x) { return e.time_s < x; });
      for (auto candidate : {it, it == lefts.begin() ? it : it - 1}) {
        if (candidate != lefts.end() && std::fabs(candidate->time_s - t) < 1e-3) {
          left_paths_[i] = candidate->path;
          break;
        }
      }
    }
  }

  poses_ = PoseTrack(config.pose_max_gap_s, config.pose_tolerance_s);
  poses_rejected_ = 0;
  warnings_.clear();
  const std::string trajectory = join(dir, "groundtruth.txt");
  if (std::filesystem::exists(trajectory)) {
    pose_counts_ = PoseListCounts{};
    return load_trajectory(trajectory, &poses_, &poses_rejected_, &warnings_, error, filter,
                           &pose_counts_);
  }
  // The INS's own records (FORMATS.md §1), decoded by the vehicle links.
  if (ins_logs == nullptr) {
    *error = dir + ": no groundtruth.txt (its INS log needs the vehicle links' decoders)";
    return false;
  }
  const std::unique_ptr<hal::PoseSource> source = ins_logs->open(dir, camera_, filter.gate, error);
  if (!source) return false;
  const hal::PoseLogRead read = hal::read_to_end(*source, &poses_);
  poses_rejected_ = static_cast<int>(read.refused_by_track);
  const hal::PoseSourceCounters& c = read.counters;
  poses_rejected_ += static_cast<int>(c.gate.rejected_total() + c.malformed);
  pose_counts_.log_malformed = c.malformed;
  pose_counts_.log_implausible = c.gate.rejected_total();
  if (poses_rejected_ > 0) {
    warnings_.push_back(std::string(source->name()) + ": " + std::to_string(poses_rejected_) +
                        " INS messages refused (malformed or implausible)");
  }
  return true;
}

hal::CameraFrame ReplaySequence::make_frame() const {
  hal::CameraFrame frame;
  const auto pixels =
      static_cast<std::size_t>(camera_.width) * static_cast<std::size_t>(camera_.height);
  frame.depth.assign(pixels, 0);
  frame.left.assign(pixels, 0);
  return frame;
}

bool ReplaySequence::read(std::size_t i, hal::CameraFrame* frame, std::string* why) const {
  const FrameListEntry& entry = frames_[i];
  frame->time_s = entry.time_s;
  frame->has_left = false;
  frame->left_problem.clear();
  if (!entry.time_in_order) {
    *why = "depth.txt:" + std::to_string(entry.line) + ": " + to_string(entry.time_verdict);
    return false;
  }
  if (!hal::read_png_gray16(entry.path, camera_.width, camera_.height, frame->depth.data(), why)) {
    return false;
  }
  if (!left_paths_[i].empty()) {
    // A bad left image only disables the sky filter for this frame: the depth is good.
    frame->has_left = hal::read_png_gray8(left_paths_[i], camera_.width, camera_.height,
                                          frame->left.data(), &frame->left_problem);
  }
  return true;
}

}  // namespace zonemap::replay
