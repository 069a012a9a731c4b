// OUT/report.html: one self-contained page of a run that opens offline in any
// browser: the height profile, a 3-D view (three.js, bundled at build time), the
// evaluation against objects.yaml when there is one, the frame-time and latency
// histograms, and every counter of stats.json. Everything is inlined.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "zonemap/features/feature_map.hpp"

namespace zonemap::tools {

struct ReportInputs {
  std::string title;                                   // the sequence, say
  std::string stats_json;                              // stats.json as written
  std::string evaluation_json;                         // eval.json's text; empty: no objects.yaml
  std::string height_png;                              // height.png's bytes
  std::vector<ObstacleBox> boxes;                      // as boxes.csv (obstacles, then ground)
  std::vector<std::vector<FootprintRect>> footprints;  // per box (may be empty)
  std::vector<Eigen::Vector3d> trajectory;
  std::vector<float> occupied;   // x, y, z per occupied cell (a sample when there are many)
  std::vector<double> frame_ms;  // mapping time per frame
  std::vector<std::pair<double, std::uint64_t>> end_to_end_bins;  // (upper edge ms, count)
  bool world_z_up = true;
  double cell_size_m = 1.0;
};

// The most occupied cells the page carries (a regular sample beyond).
inline constexpr std::size_t kReportOccupiedCells = 150000;

bool write_report(const std::string& path, const ReportInputs& inputs, std::string* error);
// Whether this build carries the 3-D view (npm was reachable when it was built).
bool report_has_3d_view();

}  // namespace zonemap::tools
