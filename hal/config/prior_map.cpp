#include "hal/config/prior_map.hpp"

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>

namespace zonemap::hal {
namespace {

// One boxes.csv row's fields: id,kind,xmin,ymin,zmin,xmax,ymax,zmax[,...].
std::vector<std::string> fields_of(const std::string& line) {
  std::vector<std::string> fields;
  std::stringstream in(line);
  std::string field;
  while (std::getline(in, field, ',')) fields.push_back(field);
  return fields;
}

bool parse_number(const std::string& text, double* value) {
  char* end = nullptr;
  *value = std::strtod(text.c_str(), &end);
  return !text.empty() && end == text.c_str() + text.size();
}

// Why a box cannot be an obstacle, or empty.
std::string check_box(const PriorBox& b) {
  for (int a = 0; a < 3; ++a) {
    if (!std::isfinite(b.min[a]) || !std::isfinite(b.max[a])) return "a coordinate is not a number";
    if (b.max[a] < b.min[a]) return "the box is inside out (a max below its min)";
    if (b.max[a] - b.min[a] > kPriorMaxExtentM) return "the box is wider than 1 km";
    if (std::abs(b.min[a]) > kPriorFarthestM || std::abs(b.max[a]) > kPriorFarthestM) {
      return "the box lies over 1,000 km from the origin (another frame?)";
    }
  }
  if (b.min.z() < kPriorLowestM) return "the box reaches below -1 km";
  return {};
}

}  // namespace

bool load_prior_map(const std::string& path, PriorMap* map, std::string* error) {
  *map = PriorMap{};
  std::ifstream in(path);
  if (!in) {
    *error = path + ": cannot open the prior map";
    return false;
  }
  std::string line;
  int number = 0;
  const auto fail = [&](const std::string& why) {
    *error = path + ":" + std::to_string(number) + ": " + why;
    map->boxes.clear();
    return false;
  };
  while (std::getline(in, line)) {
    ++number;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (number == 1) {
      if (line.rfind("id,kind,xmin,ymin,zmin,xmax,ymax,zmax", 0) != 0) {
        return fail(
            "not a boxes.csv (its header must start id,kind,xmin,ymin,zmin,xmax,ymax,zmax)");
      }
      continue;
    }
    if (line.empty() || line[0] == '#') continue;
    const std::vector<std::string> f = fields_of(line);
    if (f.size() < 8) return fail("expected id,kind,xmin,ymin,zmin,xmax,ymax,zmax");
    if (f[1] == "ground") {
      ++map->ground_rows_skipped;
      continue;
    }
    if (f[1] != "obstacle") return fail("kind must be obstacle or ground, not '" + f[1] + "'");
    PriorBox b;
    b.line = number;
    double v[6];
    for (int i = 0; i < 6; ++i) {
      if (!parse_number(f[2 + i], &v[i])) return fail("'" + f[2 + i] + "' is not a number");
    }
    b.min = Eigen::Vector3d(v[0], v[1], v[2]);
    b.max = Eigen::Vector3d(v[3], v[4], v[5]);
    const std::string why = check_box(b);
    if (!why.empty()) return fail(why);
    map->boxes.push_back(b);
  }
  return true;
}

}  // namespace zonemap::hal
