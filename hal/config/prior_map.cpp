#include "hal/config/prior_map.hpp"

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include "zonemap/common/geodetic.hpp"

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

}  // namespace

std::string prior_box_problem(const PriorBox& b, bool world_z_up) {
  for (int a = 0; a < 3; ++a) {
    if (!std::isfinite(b.min[a]) || !std::isfinite(b.max[a])) return "a coordinate is not a number";
    if (b.max[a] < b.min[a]) return "the box is inside out (a max below its min)";
    if (b.max[a] - b.min[a] > kPriorMaxExtentM) return "the box is wider than 1 km";
    if (std::abs(b.min[a]) > kPriorFarthestM || std::abs(b.max[a]) > kPriorFarthestM) {
      return "the box lies over 1,000 km from the origin (another frame?)";
    }
  }
  // Height is z up, -z in NED.
  if ((world_z_up ? b.min.z() : -b.max.z()) < kPriorLowestM) return "the box reaches below -1 km";
  return {};
}

namespace {

// Reads lines, numbering them; fail() names the file and line.
struct LineReader {
  std::ifstream in;
  std::string path;
  int number = 0;
  bool next(std::string* line) {
    if (!std::getline(in, *line)) return false;
    ++number;
    if (!line->empty() && line->back() == '\r') line->pop_back();
    return true;
  }
  bool fail(PriorMap* map, std::string* error, const std::string& why) const {
    *error = path + ":" + std::to_string(number) + ": " + why;
    map->boxes.clear();
    return false;
  }
};

bool parse_numbers(const std::vector<std::string>& f, std::size_t first, std::size_t count,
                   double* out, std::string* bad) {
  for (std::size_t i = 0; i < count; ++i) {
    if (!parse_number(f[first + i], &out[i])) {
      *bad = "'" + f[first + i] + "' is not a number";
      return false;
    }
  }
  return true;
}

bool read_boxes_csv(LineReader& r, bool world_z_up, PriorMap* map, std::string* error) {
  std::string line;
  while (r.next(&line)) {
    if (line.empty() || line[0] == '#') continue;
    const std::vector<std::string> f = fields_of(line);
    if (f.size() < 8) return r.fail(map, error, "expected id,kind,xmin,ymin,zmin,xmax,ymax,zmax");
    if (f[1] == "ground") {
      ++map->ground_rows_skipped;
      continue;
    }
    if (f[1] != "obstacle")
      return r.fail(map, error, "kind must be obstacle or ground, not '" + f[1] + "'");
    double v[6];
    std::string why;
    if (!parse_numbers(f, 2, 6, v, &why)) return r.fail(map, error, why);
    PriorBox b;
    b.line = r.number;
    b.min = Eigen::Vector3d(v[0], v[1], v[2]);
    b.max = Eigen::Vector3d(v[3], v[4], v[5]);
    why = prior_box_problem(b, world_z_up);
    if (!why.empty()) return r.fail(map, error, why);
    map->boxes.push_back(b);
  }
  return true;
}

// A surveyed obstacle (base point, radius, height) as a box about the origin.
PriorBox survey_box(const LocalTangentPlane& plane, const double v[5], bool world_z_up) {
  const Eigen::Vector3d base = plane.to_ned(Geodetic{v[0], v[1], v[2]});
  const double r = v[3];
  PriorBox b;
  if (!world_z_up) {
    b.min = Eigen::Vector3d(base.x() - r, base.y() - r, base.z() - v[4]);
    b.max = Eigen::Vector3d(base.x() + r, base.y() + r, base.z());
  } else {  // north, west, up
    b.min = Eigen::Vector3d(base.x() - r, -base.y() - r, -base.z());
    b.max = Eigen::Vector3d(base.x() + r, -base.y() + r, -base.z() + v[4]);
  }
  return b;
}

bool read_survey(LineReader& r, bool world_z_up, PriorMap* map, std::string* error) {
  std::string line;
  LocalTangentPlane plane;
  bool header = false;
  while (r.next(&line)) {
    if (line.empty() || line[0] == '#') continue;
    const std::vector<std::string> f = fields_of(line);
    std::string why;
    if (!plane.has_origin()) {
      double o[3];
      if (f.size() != 4 || f[0] != "origin") {
        return r.fail(map, error, "a survey first gives origin,LATITUDE,LONGITUDE,HEIGHT");
      }
      if (!parse_numbers(f, 1, 3, o, &why)) return r.fail(map, error, why);
      if (!(std::abs(o[0]) <= 90.0 && std::abs(o[1]) <= 180.0)) {
        return r.fail(map, error, "the origin is not a WGS84 latitude and longitude");
      }
      plane = LocalTangentPlane(Geodetic{o[0], o[1], o[2]});
      continue;
    }
    if (!header) {
      if (line.rfind("name,latitude_deg,longitude_deg,base_height_m,radius_m,height_m", 0) != 0) {
        return r.fail(map, error,
                      "expected the header name,latitude_deg,longitude_deg,base_height_m,radius_m,"
                      "height_m");
      }
      header = true;
      continue;
    }
    if (f.size() != 6) return r.fail(map, error, "expected name,lat,lon,base_height,radius,height");
    double v[5];
    if (!parse_numbers(f, 1, 5, v, &why)) return r.fail(map, error, why);
    if (!(std::abs(v[0]) <= 90.0 && std::abs(v[1]) <= 180.0)) {
      return r.fail(map, error, "not a WGS84 latitude and longitude");
    }
    if (!(v[3] > 0.0) || !(v[4] > 0.0)) return r.fail(map, error, "radius and height must be > 0");
    PriorBox b = survey_box(plane, v, world_z_up);
    b.line = r.number;
    why = prior_box_problem(b, world_z_up);
    if (!why.empty()) return r.fail(map, error, why);
    map->boxes.push_back(b);
  }
  if (!plane.has_origin()) return r.fail(map, error, "a survey without its origin");
  return true;
}

}  // namespace

bool load_prior_map(const std::string& path, bool world_z_up, PriorMap* map, std::string* error) {
  *map = PriorMap{};
  LineReader r;
  r.path = path;
  r.in.open(path);
  if (!r.in) {
    *error = path + ": cannot open the prior map";
    return false;
  }
  std::string first;
  if (!r.next(&first)) return r.fail(map, error, "empty: not a boxes.csv or a survey");
  if (first.rfind("# zonemap survey", 0) == 0) return read_survey(r, world_z_up, map, error);
  if (first.rfind("id,kind,xmin,ymin,zmin,xmax,ymax,zmax", 0) != 0) {
    return r.fail(map, error,
                  "not a boxes.csv (its header must start id,kind,xmin,ymin,zmin,xmax,ymax,zmax) "
                  "nor a survey (# zonemap survey)");
  }
  return read_boxes_csv(r, world_z_up, map, error);
}

}  // namespace zonemap::hal
