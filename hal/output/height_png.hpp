// height.png: the height profile (paper fig. 11) drawn from above. Colour =
// height of a column's top cell, blank = unknown, the trajectory in black (a
// square at its start), `outlines` as rectangles [min x, min y, max x, max y], a
// colour bar with heights in metres and a scale bar.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "zonemap/outputs/height_profile.hpp"

namespace zonemap::hal {

bool write_height_png(const std::string& path, const HeightProfile& profile, double cell_size_m,
                      const std::vector<Eigen::Vector3d>& trajectory,
                      const std::vector<Eigen::Vector4d>& outlines, std::string* error);

}  // namespace zonemap::hal
