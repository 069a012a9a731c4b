#include "tools/eval/evaluate.hpp"

#include <yaml-cpp/yaml.h>

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
      objects->push_back(t);
    }
  } catch (const YAML::BadFile&) {
    *error = path + ": cannot open";
    return false;
  } catch (const YAML::Exception& e) {
    *error = path + ":" + std::to_string(e.mark.line + 1) + ": " + e.msg;
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

Evaluation evaluate(const std::vector<TruthObject>& objects, const std::vector<RunBox>& boxes,
                    double tolerance_m) {
  Evaluation e;
  int detected = 0;
  for (const TruthObject& o : objects) {
    ObjectResult r;
    r.name = o.name;
    double best = INFINITY;
    for (const RunBox& b : boxes) {
      if (b.kind != "obstacle" || !overlaps(o.min, o.max, b.min, b.max, tolerance_m)) continue;
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
    detected += r.detected ? 1 : 0;
    e.objects.push_back(r);
  }
  for (const RunBox& b : boxes) {
    if (b.kind != "obstacle") continue;
    ++e.obstacle_boxes;
    bool touches = false;
    for (const TruthObject& o : objects)
      touches = touches || overlaps(o.min, o.max, b.min, b.max, tolerance_m);
    if (!touches) ++e.boxes_touching_no_object;
  }
  e.recall =
      objects.empty() ? 1.0 : static_cast<double>(detected) / static_cast<double>(objects.size());
  e.false_box_fraction = e.obstacle_boxes == 0 ? 0.0
                                               : static_cast<double>(e.boxes_touching_no_object) /
                                                     static_cast<double>(e.obstacle_boxes);
  return e;
}

std::string to_json(const Evaluation& e) {
  std::ostringstream out;
  char buf[256];
  out << "{\n  \"recall\": " << e.recall << ",\n  \"obstacle_boxes\": " << e.obstacle_boxes
      << ",\n  \"boxes_touching_no_object\": " << e.boxes_touching_no_object
      << ",\n  \"false_box_fraction\": " << e.false_box_fraction << ",\n  \"objects\": [";
  for (std::size_t i = 0; i < e.objects.size(); ++i) {
    const ObjectResult& r = e.objects[i];
    std::snprintf(buf, sizeof(buf),
                  "%s\n    {\"name\": \"%s\", \"detected\": %s, \"box_id\": %u, "
                  "\"centre_error_xy_m\": %.3f, \"box_centre\": [%.3f, %.3f]}",
                  i ? "," : "", r.name.c_str(), r.detected ? "true" : "false", r.box_id,
                  r.centre_error_xy_m, r.box_centre.x(), r.box_centre.y());
    out << buf;
  }
  out << "\n  ]\n}\n";
  return out.str();
}

std::string to_table(const Evaluation& e) {
  std::ostringstream out;
  char buf[256];
  std::snprintf(buf, sizeof(buf), "%-22s %-9s %6s %12s\n", "object", "detected", "box",
                "xy error m");
  out << buf;
  for (const ObjectResult& r : e.objects) {
    std::snprintf(buf, sizeof(buf), "%-22s %-9s %6u %12.2f\n", r.name.c_str(),
                  r.detected ? "yes" : "NO", r.box_id, r.centre_error_xy_m);
    out << buf;
  }
  std::snprintf(
      buf, sizeof(buf), "recall %.1f%%; %d obstacle boxes, %d (%.1f%%) touching no object\n",
      100.0 * e.recall, e.obstacle_boxes, e.boxes_touching_no_object, 100.0 * e.false_box_fraction);
  out << buf;
  return out.str();
}

}  // namespace zonemap::tools
