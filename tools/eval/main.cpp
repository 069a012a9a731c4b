// zonemap-eval SEQUENCE RUN_DIR [--tolerance M]
// Compares RUN_DIR/boxes.csv with SEQUENCE/objects.yaml; writes RUN_DIR/eval.json
// and prints a table. The tolerance (default: the run's cell size from
// stats.json, else 0.5 m) is how far a box may miss an object and still count.
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>

#include "hal/config/yaml_config.hpp"
#include "tools/eval/evaluate.hpp"
#include "zonemap/common/camera.hpp"

namespace {
// Eq. (1)'s Δd at 1 m for SEQUENCE/camera.yaml (Δd = d² times it); 0 when the
// camera cannot be read: the allowances are then not judged.
double range_resolution_factor(const std::string& sequence) {
  zonemap::CameraModel camera;
  std::string error;
  if (!zonemap::hal::load_camera_yaml(sequence + "/camera.yaml", &camera, &error)) return 0.0;
  return zonemap::range_resolution(camera, 1.0);
}
}  // namespace

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: zonemap-eval SEQUENCE RUN_DIR [--tolerance M]\n");
    return 2;
  }
  const std::string sequence = argv[1];
  const std::string run = argv[2];
  double tolerance = -1.0;
  for (int i = 3; i < argc; ++i) {
    if (std::string(argv[i]) == "--tolerance" && i + 1 < argc) {
      tolerance = std::atof(argv[++i]);
    } else {
      std::fprintf(stderr, "zonemap-eval: unknown argument %s\n", argv[i]);
      return 2;
    }
  }
  if (tolerance < 0.0) {
    std::ifstream stats(run + "/stats.json");
    std::stringstream text;
    text << stats.rdbuf();
    const std::string s = text.str();
    const std::string key = "\"cell_size_m\":";
    const auto at = s.find(key);
    tolerance = at == std::string::npos ? 0.5 : std::atof(s.c_str() + at + key.size());
    if (!(tolerance > 0.0)) tolerance = 0.5;
  }
  std::vector<zonemap::tools::TruthObject> objects;
  std::vector<zonemap::tools::RunBox> boxes;
  std::string error;
  if (!zonemap::tools::load_objects_yaml(sequence + "/objects.yaml", &objects, &error) ||
      !zonemap::tools::load_boxes_csv(run + "/boxes.csv", &boxes, &error)) {
    std::fprintf(stderr, "zonemap-eval: %s\n", error.c_str());
    return 1;
  }
  const auto evaluation =
      zonemap::tools::evaluate(objects, boxes, tolerance, range_resolution_factor(sequence));
  std::ofstream(run + "/eval.json") << zonemap::tools::to_json(evaluation);
  std::printf("%s(tolerance %.2f m) -> %s/eval.json\n",
              zonemap::tools::to_table(evaluation).c_str(), tolerance, run.c_str());
  return 0;
}
