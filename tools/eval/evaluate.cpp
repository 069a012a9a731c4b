#include "tools/eval/evaluate.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>

namespace zonemap::tools {
namespace {

bool overlaps(const Eigen::Vector3d& a0, const Eigen::Vector3d& a1, const Eigen::Vector3d& b0,
              const Eigen::Vector3d& b1, double grow) {
  return (a0.array() <= b1.array() + grow).all() && (b0.array() <= a1.array() + grow).all();
}

}  // namespace

bool load_objects_yaml(const std::string& path, std::vector<TruthObject>* objects,
                       std::string* error) {
  try {
    const YAML::Node root = YAML::LoadFile(path);
    const YAML::Node list = root["objects"];
    if (!list || !list.IsSequence()) {
      *error = path + ": no 'objects' list";
      return false;
    }
    for (const YAML::Node& o : list) {
      TruthObject t;
      t.name = o["name"].as<std::string>("");
      const std::string type = o["type"].as<std::string>("");
      if (type == "cylinder") {
        const auto c = o["center"].as<std::vector<double>>();
        const double r = o["radius"].as<double>();
        const auto z = o["z"].as<std::vector<double>>();
        if (c.size() != 2 || z.size() != 2)
          throw YAML::Exception(o.Mark(), "cylinder needs center [x, y] and z [min, max]");
        t.centre = Eigen::Vector2d(c[0], c[1]);
        t.cylinder = true;
        t.radius = r;
        t.min = Eigen::Vector3d(c[0] - r, c[1] - r, z[0]);
        t.max = Eigen::Vector3d(c[0] + r, c[1] + r, z[1]);
      } else if (type == "box") {
        const auto lo = o["min"].as<std::vector<double>>();
        const auto hi = o["max"].as<std::vector<double>>();
        if (lo.size() != 3 || hi.size() != 3)
          throw YAML::Exception(o.Mark(), "box needs min and max [x, y, z]");
        t.min = Eigen::Vector3d(lo[0], lo[1], lo[2]);
        t.max = Eigen::Vector3d(hi[0], hi[1], hi[2]);
        t.centre = Eigen::Vector2d((lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2);
      } else {
        throw YAML::Exception(o.Mark(), "unknown object type '" + type + "'");
      }
      if (o["pixel_hits"]) t.pixel_hits = o["pixel_hits"].as<std::int64_t>();
      if (o["seen_top_z"]) t.seen_top_z = o["seen_top_z"].as<double>();
      if (o["nearest_seen_m"]) t.nearest_seen_m = o["nearest_seen_m"].as<double>();
      t.moving = o["moving"].as<bool>(false);
      objects->push_back(t);
    }
  } catch (const YAML::BadFile&) {
    *error = path + ": cannot open";
    return false;
  } catch (const YAML::Exception& e) {
    *error = path + ":" + std::to_string(e.mark.line + 1) + ": " + e.msg;
    return false;
  } catch (const std::exception& e) {  // a directory: std::ios_base::failure
    *error = path + ": cannot read (" + e.what() + ")";
    return false;
  }
  return true;
}

bool load_boxes_csv(const std::string& path, std::vector<RunBox>* boxes, std::string* error) {
  std::ifstream in(path);
  if (!in) {
    *error = path + ": cannot open";
    return false;
  }
  std::string line;
  int number = 0;
  while (std::getline(in, line)) {
    ++number;
    if (number == 1 || line.empty()) continue;  // header
    std::replace(line.begin(), line.end(), ',', ' ');
    std::istringstream fields(line);
    RunBox b;
    if (!(fields >> b.id >> b.kind >> b.min.x() >> b.min.y() >> b.min.z() >> b.max.x() >>
          b.max.y() >> b.max.z() >> b.cells)) {
      *error = path + ":" + std::to_string(number) +
               ": expected id,kind,xmin,ymin,zmin,xmax,ymax,zmax,cells";
      return false;
    }
    boxes->push_back(b);
  }
  return true;
}

double TruthObject::distance_xy(double x, double y) const {
  if (cylinder) return std::max(0.0, std::hypot(x - centre.x(), y - centre.y()) - radius);
  const double dx = std::max({min.x() - x, 0.0, x - max.x()});
  const double dy = std::max({min.y() - y, 0.0, y - max.y()});
  return std::hypot(dx, dy);
}

namespace {

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

// Gap between two objects' x-y extents (0 when they overlap).
double gap_xy(const TruthObject& a, const TruthObject& b) {
  const double dx = std::max({a.min.x() - b.max.x(), 0.0, b.min.x() - a.max.x()});
  const double dy = std::max({a.min.y() - b.max.y(), 0.0, b.min.y() - a.max.y()});
  return std::hypot(dx, dy);
}

// The share of a box's x-y area within kPurityMarginM of some object, and its area
// (sampled on a grid of at most 200 x 200 points, at least every 0.1 m).
std::pair<double, double> pure_area(const RunBox& b, const std::vector<TruthObject>& objects) {
  const double w = b.max.x() - b.min.x(), h = b.max.y() - b.min.y();
  const int nx = std::clamp(static_cast<int>(std::ceil(w / 0.1)), 1, 200);
  const int ny = std::clamp(static_cast<int>(std::ceil(h / 0.1)), 1, 200);
  int near = 0;
  for (int i = 0; i < nx; ++i) {
    for (int j = 0; j < ny; ++j) {
      const double x = b.min.x() + (i + 0.5) * w / nx, y = b.min.y() + (j + 0.5) * h / ny;
      for (const TruthObject& o : objects) {
        if (o.distance_xy(x, y) <= kPurityMarginM) {
          ++near;
          break;
        }
      }
    }
  }
  const double area = std::max(w, 0.0) * std::max(h, 0.0);
  return {area * near / (nx * ny), area};
}

// The obstacle boxes that are the object's: those overlapping its extent, or when none
// does, those within the tolerance (a box that falls just short still finds it). A
// neighbour's box ending in the gap within the tolerance is the neighbour's, not this
// object's: counting it would call two boxes with a gap between them one joined box.
std::vector<const RunBox*> boxes_of(const TruthObject& o, const std::vector<RunBox>& boxes,
                                    double tolerance_m) {
  std::vector<const RunBox*> overlapping, near;
  for (const RunBox& b : boxes) {
    if (b.kind != "obstacle") continue;
    if (overlaps(o.min, o.max, b.min, b.max, 0.0)) overlapping.push_back(&b);
    if (overlaps(o.min, o.max, b.min, b.max, tolerance_m)) near.push_back(&b);
  }
  return overlapping.empty() ? near : overlapping;
}

// The share of [lo, hi] that [box_lo, box_hi] covers (1 for no height).
double height_share(double lo, double hi, double box_lo, double box_hi) {
  const double height = hi - lo;
  const double covered = std::min(hi, box_hi) - std::max(lo, box_lo);
  return height > 0.0 ? std::clamp(covered / height, 0.0, 1.0) : 1.0;
}

}  // namespace

Evaluation evaluate(const std::vector<TruthObject>& objects, const std::vector<RunBox>& boxes,
                    double tolerance_m, double range_resolution_factor) {
  Evaluation e;
  std::vector<double> excess, coverage, coverage_seen;
  int separated = 0, separated_wide = 0;
  for (const TruthObject& o : objects) {
    ObjectResult r;
    r.name = o.name;
    r.seen = o.pixel_hits < 0 || o.pixel_hits >= kSeenPixelHits;
    r.moving = o.moving;
    double best = INFINITY;
    Eigen::Vector3d union_min = Eigen::Vector3d::Constant(INFINITY);
    Eigen::Vector3d union_max = Eigen::Vector3d::Constant(-INFINITY);
    bool swallows_another = false, swallows_one_wide_apart = false;
    for (const RunBox* box : boxes_of(o, boxes, tolerance_m)) {
      const RunBox& b = *box;
      ++r.boxes;
      union_min = union_min.cwiseMin(b.min);
      union_max = union_max.cwiseMax(b.max);
      for (const TruthObject& other : objects) {
        if (&other == &o || !overlaps(other.min, other.max, b.min, b.max, 0.0)) continue;
        const double gap = gap_xy(o, other);
        swallows_another |= gap >= kSeparationM;
        swallows_one_wide_apart |= gap >= kWideGapM;
      }
      const Eigen::Vector2d c((b.min.x() + b.max.x()) / 2, (b.min.y() + b.max.y()) / 2);
      const double d = (c - o.centre).norm();
      if (d < best) {
        best = d;
        r.detected = true;
        r.box_id = b.id;
        r.centre_error_xy_m = d;
        r.box_centre = c;
      }
    }
    if (r.detected) {
      r.separated = !swallows_another;
      r.separated_wide = !swallows_one_wide_apart;
      r.excess_m = std::max({o.min.x() - union_min.x(), union_max.x() - o.max.x(),
                             o.min.y() - union_min.y(), union_max.y() - o.max.y(), 0.0});
      r.z_coverage = height_share(o.min.z(), o.max.z(), union_min.z(), union_max.z());
      const double seen_top =
          std::isnan(o.seen_top_z) ? o.max.z() : std::clamp(o.seen_top_z, o.min.z(), o.max.z());
      r.z_coverage_seen = height_share(o.min.z(), seen_top, union_min.z(), union_max.z());
      if (range_resolution_factor > 0.0 && std::isfinite(o.nearest_seen_m)) {
        r.excess_allowed_m =
            std::max(kExcessFloorM, range_resolution_factor * o.nearest_seen_m * o.nearest_seen_m);
      }
    }
    if (r.moving) {
      ++e.moving_objects;
    } else if (r.seen) {
      ++e.objects_seen;
      if (r.detected) {
        ++e.objects_found;
        separated += r.separated ? 1 : 0;
        separated_wide += r.separated_wide ? 1 : 0;
        excess.push_back(r.excess_m);
        if (!std::isnan(r.excess_allowed_m)) {
          ++e.excess_judged;
          e.excess_within += r.excess_m <= r.excess_allowed_m + 1e-9 ? 1 : 0;
        }
        coverage.push_back(r.z_coverage);
        coverage_seen.push_back(r.z_coverage_seen);
      }
    }
    e.objects.push_back(r);
  }
  double pure = 0.0, area = 0.0;
  for (const RunBox& b : boxes) {
    if (b.kind != "obstacle") continue;
    ++e.obstacle_boxes;
    bool touches = false;
    for (const TruthObject& o : objects)
      touches = touches || overlaps(o.min, o.max, b.min, b.max, tolerance_m);
    if (!touches) ++e.boxes_touching_no_object;
    const auto [p, a] = pure_area(b, objects);
    pure += p;
    area += a;
  }
  e.recall = e.objects_seen == 0 ? 1.0 : static_cast<double>(e.objects_found) / e.objects_seen;
  e.false_box_fraction = e.obstacle_boxes == 0 ? 0.0
                                               : static_cast<double>(e.boxes_touching_no_object) /
                                                     static_cast<double>(e.obstacle_boxes);
  e.separated = e.objects_found == 0 ? 0.0 : static_cast<double>(separated) / e.objects_found;
  e.separated_wide =
      e.objects_found == 0 ? 0.0 : static_cast<double>(separated_wide) / e.objects_found;
  e.excess_median_m = median(excess);
  e.excess_max_m = excess.empty() ? 0.0 : *std::max_element(excess.begin(), excess.end());
  e.purity = area > 0.0 ? pure / area : 1.0;
  e.z_coverage_median = median(coverage);
  e.z_coverage_min = coverage.empty() ? 0.0 : *std::min_element(coverage.begin(), coverage.end());
  e.z_coverage_seen_median = median(coverage_seen);
  e.z_coverage_seen_min =
      coverage_seen.empty() ? 0.0 : *std::min_element(coverage_seen.begin(), coverage_seen.end());
  return e;
}

namespace {
std::string allowed_json(double allowed) {
  if (std::isnan(allowed)) return "null";
  char text[32];
  std::snprintf(text, sizeof(text), "%.2f", allowed);
  return text;
}
}  // namespace

std::string to_json(const Evaluation& e) {
  std::ostringstream out;
  char buf[512];
  out << "{\n  \"recall\": " << e.recall << ",\n  \"obstacle_boxes\": " << e.obstacle_boxes
      << ",\n  \"boxes_touching_no_object\": " << e.boxes_touching_no_object
      << ",\n  \"false_box_fraction\": " << e.false_box_fraction
      << ",\n  \"objects_seen\": " << e.objects_seen
      << ",\n  \"objects_found\": " << e.objects_found
      << ",\n  \"moving_objects\": " << e.moving_objects << ",\n  \"separated\": " << e.separated
      << ",\n  \"separated_wide_gaps\": " << e.separated_wide
      << ",\n  \"excess_m\": {\"median\": " << e.excess_median_m << ", \"max\": " << e.excess_max_m
      << "}"
      << ",\n  \"excess_within_allowed\": {\"judged\": " << e.excess_judged
      << ", \"within\": " << e.excess_within << "}"
      << ",\n  \"purity\": " << e.purity
      << ",\n  \"z_coverage\": {\"median\": " << e.z_coverage_median
      << ", \"min\": " << e.z_coverage_min << "}"
      << ",\n  \"z_coverage_seen\": {\"median\": " << e.z_coverage_seen_median
      << ", \"min\": " << e.z_coverage_seen_min << "}"
      << ",\n  \"false_boxes\": " << e.boxes_touching_no_object << ",\n  \"objects\": [";
  for (std::size_t i = 0; i < e.objects.size(); ++i) {
    const ObjectResult& r = e.objects[i];
    // The name goes in apart: objects.yaml's names have no length limit.
    out << (i ? "," : "") << "\n    {\"name\": \"" << r.name << "\", ";
    std::snprintf(buf, sizeof(buf),
                  "\"seen\": %s, \"moving\": %s, \"detected\": %s, "
                  "\"box_id\": %u, "
                  "\"centre_error_xy_m\": %.3f, \"box_centre\": [%.3f, %.3f], \"boxes\": %d, "
                  "\"separated\": %s, \"excess_m\": %.2f, \"excess_allowed_m\": %s, "
                  "\"z_coverage\": %.3f, \"z_coverage_seen\": %.3f}",
                  r.seen ? "true" : "false", r.moving ? "true" : "false",
                  r.detected ? "true" : "false", r.box_id, r.centre_error_xy_m, r.box_centre.x(),
                  r.box_centre.y(), r.boxes, r.separated ? "true" : "false", r.excess_m,
                  allowed_json(r.excess_allowed_m).c_str(), r.z_coverage, r.z_coverage_seen);
    out << buf;
  }
  out << "\n  ]\n}\n";
  return out.str();
}

std::string to_table(const Evaluation& e) {
  std::ostringstream out;
  char buf[512];
  std::snprintf(buf, sizeof(buf), "%-22s %-5s %-9s %6s %11s %9s %9s %9s %7s %7s\n", "object",
                "seen", "detected", "box", "xy error m", "separate", "excess m", "allowed m",
                "z cover", "of seen");
  out << buf;
  for (const ObjectResult& r : e.objects) {
    char allowed[16] = "-";
    if (!std::isnan(r.excess_allowed_m)) {
      std::snprintf(allowed, sizeof(allowed), "%.2f%s", r.excess_allowed_m,
                    r.excess_m > r.excess_allowed_m + 1e-9 ? "!" : "");
    }
    std::snprintf(buf, sizeof(buf), "%-22s %-5s %-9s %6u %11.2f %9s %9.2f %9s %6.0f%% %6.0f%%\n",
                  r.name.c_str(), r.moving ? "moved" : (r.seen ? "yes" : "no"),
                  r.detected ? "yes" : "NO", r.box_id, r.centre_error_xy_m,
                  r.detected ? (r.separated ? "yes" : "NO") : "-", r.excess_m, allowed,
                  100.0 * r.z_coverage, 100.0 * r.z_coverage_seen);
    out << buf;
  }
  std::snprintf(buf, sizeof(buf),
                "recall %.1f%% (%d of %d seen); separated %.0f%% (over gaps >= %.1f m: %.0f%%); "
                "excess median %.2f m, max "
                "%.2f m; purity %.0f%%; z coverage median %.0f%%, min %.0f%% (of the height seen "
                "%.0f%%, %.0f%%); %d obstacle boxes, %d false (touching no object)\n",
                100.0 * e.recall, e.objects_found, e.objects_seen, 100.0 * e.separated, kWideGapM,
                100.0 * e.separated_wide, e.excess_median_m, e.excess_max_m, 100.0 * e.purity,
                100.0 * e.z_coverage_median, 100.0 * e.z_coverage_min,
                100.0 * e.z_coverage_seen_median, 100.0 * e.z_coverage_seen_min, e.obstacle_boxes,
                e.boxes_touching_no_object);
  out << buf;
  if (e.excess_judged > 0) {
    std::snprintf(buf, sizeof(buf),
                  "excess within what the views allow (max(%.1f m, eq. 1's range resolution at "
                  "the nearest depth seen)): %d of %d\n",
                  kExcessFloorM, e.excess_within, e.excess_judged);
    out << buf;
  }
  if (e.moving_objects > 0) {
    std::snprintf(buf, sizeof(buf),
                  "%d moving object(s): counted where they are at the end; boxes left where they "
                  "were are false\n",
                  e.moving_objects);
    out << buf;
  }
  return out.str();
}

}  // namespace zonemap::tools
